"""Run one scenario: MuJoCo truth stepped at dt, the pipeline sampled at its own period.

Per control tick k (t = k Tc): record the truth (at the trace period), run the pipeline on
the state at t, hold its command (zero-order hold) for the Tc / dt physics steps to t + Tc.
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.linalg  # noqa: F401  (loads SciPy's own OpenBLAS, so that threadpoolctl finds it)
from threadpoolctl import ThreadpoolController

from testbed import metrics
from testbed.recording import trace
from testbed.recording.output_paths import output_path
from testbed.references import registry as references_registry
from testbed.systems import registry as systems_registry
from testbed.environment import surroundings
from testbed.errors import InputError, error_line, refused_as
from testbed.exit_guard import os_exit_raises
from testbed.pipeline import Pipeline, StageContext, StageFailed, params_dict, stage_infos
from testbed.plant import SimulationDiverged
from testbed.recording.recorder import FLUSH_AFTER_S, Chunk, Recorder, Trace
from testbed.recording.reductions import Reductions


_blas_controller: ThreadpoolController | None = None


def one_blas_thread():
    """A context in which every BLAS library of this process runs on the calling thread only
    (the libraries are listed once, at the first call: about 3 ms)."""
    # The matrices here have a few rows, yet OpenBLAS hands some to its pool (SciPy's expm in the
    # gimbal servo, at every plant build), whose threads then spin about 55 ms of CPU on another
    # core for no speed-up: 6 % of a core during a one-second run, taken from a campaign's other
    # worker. threadpoolctl limits the pools of every BLAS library loaded in the process.
    global _blas_controller
    if _blas_controller is None:
        _blas_controller = ThreadpoolController()
    return _blas_controller.limit(limits=1, user_api="blas")


@dataclass
class RunData:
    """What metrics see after a run: the scenario, the trace, each stage's declared
    statistics (slot -> counts over every control step, e.g. the steering extremes) and
    the plant's static design data (`Plant.description`)."""

    scenario: object
    recorder: Recorder
    statistics: dict
    description: object
    momentum_scale: float
    reference_error: str | None = None  # why the reference signals are missing, if they are
    # figures derived from the trace that several metrics share (see `shared`)
    _shared: dict = field(default_factory=dict)
    reductions: Reductions = field(default_factory=Reductions)  # the running reductions the metrics declared

    def reduced(self, reduction):
        """The value of a running reduction a metric declared (`testbed.metrics.metric(uses=)`)."""
        return self.reductions.value(reduction)

    def shared(self, key: str, compute):
        """compute() once per run for metrics that share an expensive derived figure."""
        if key not in self._shared:
            self._shared[key] = compute()
        return self._shared[key]


@dataclass
class RunResult:
    """The outcome of a run (or of an `.rrd` read back): status, metrics, checks and the trace.

    status: "ok", "diverged" (MuJoCo hit a bad state) or "error" (a stage raised or returned
    bad output); error: the one-line reason, else None; metrics: name -> value; checks: one
    dict per check (name, value, limit, passed); trace: every recorded signal as numpy arrays
    (`result.trace["truth/omega"] -> (t, values)`); data: what the metrics saw (kept on request).
    """

    scenario: str
    sim_s: float
    wall_s: float
    status: str
    error: str | None
    metrics: dict[str, float]
    checks: list[dict]
    rrd: str | None
    data: RunData | None = None
    trace: Trace | None = None

    @property
    def passed(self) -> bool:
        return self.status == "ok" and all(c["passed"] for c in self.checks)

    def as_json(self) -> dict:
        return {"scenario": self.scenario, "sim_s": self.sim_s, "wall_s": self.wall_s,
                "status": self.status, "error": self.error, "metrics": self.metrics,
                "checks": self.checks, "rrd": self.rrd}


def prepare(scenario):
    """Build the plant, the pipeline and the reference: every design-time check happens here.

    Parameters so extreme that building from them overflows or breaks a factorisation are bad
    input, named by the part being built (model, pipeline slot, reference)."""
    scenario = surroundings.in_orbit(scenario)  # an initial state given in LVLH, in ECI
    with np.errstate(all="raise"), refused_as("model"):
        plant = systems_registry.make_plant(scenario)
        plant.record_energy = scenario.stages["allocator"][0] == "none" and scenario.environment is None
        plant.initialise(scenario.initial)
        plant.surroundings = surroundings.prepare(scenario, plant)
        ctx = stage_context(scenario, plant.locked_inertia(), plant.description(), plant.actuator_state(),
                            plant.internal_momentum_body())
    with np.errstate(all="raise"):
        pipeline = Pipeline.from_config(scenario.stages, ctx, plant.actuators)
    output = getattr(pipeline.allocator, "output", None)
    if output is not None and output not in plant.actuators:
        raise InputError("pipeline.allocator.type", f"{scenario.stages['allocator'][0]} commands {output}, "
                         f"which model.system {scenario.system} does not have")
    references_registry.check_system(scenario)  # after the stages: a reference describes them
    with np.errstate(all="raise"), refused_as("reference"):
        reference = references_registry.prepare(scenario, plant) if scenario.reference else None
    return plant, pipeline, reference


def stage_context(scenario, inertia, description=None, actuators=None, internal_momentum=None) -> StageContext:
    """What the stages of `scenario` may know at construction (testbed.pipeline.StageContext);
    `actuators`: the plant's actuator read-outs at t = 0, `internal_momentum` its H(0)."""
    sim = scenario.sim
    return StageContext(dt=sim.dt_s, control_period=sim.control_period_s, sample_period=sim.estimator_period_s,
                        inertia=inertia,
                        internal_momentum=np.zeros(3) if internal_momentum is None else internal_momentum,
                        description=description, system=scenario.system, model=scenario.model,
                        free_flying=systems_registry.is_free_flying(scenario),
                        initial=scenario.initial, integrator=sim.integrator,
                        end_time=round(sim.duration_s / sim.control_period_s) * sim.control_period_s,
                        stages=stage_infos(scenario.stages), actuators=dict(actuators or {}),
                        orbit=scenario.orbit)


def run_scenario(scenario, out: Path | None, progress=None, keep_data: bool = False,
                 live=None, on_prepared=None) -> RunResult:
    """Run `scenario`, stream the trace to `out` (None: no file) and evaluate its checks;
    `keep_data` keeps the whole trace and what the metrics saw in the result (otherwise only the
    signals the metrics need are kept: memory does not grow with the run for metrics that are
    running reductions); `live`: a viewer (testbed.recording.live_view.ViewerStream) the trace is also
    streamed to as it goes, never waited for; the file and the viewer get a chunk at least
    every FLUSH_AFTER_S of wall time; `progress(fraction)` is called about 200 times;
    `on_prepared(plant, pipeline)` sees the built plant and stages before the first step (a
    campaign reads back what the case runs with). os._exit called by a plug-in's code raises
    (testbed.exit_guard), so that a stage that calls it fails the run."""
    with one_blas_thread(), os_exit_raises():
        return _run(scenario, out, progress, keep_data, live, on_prepared)


def _run(scenario, out, progress, keep_data, live, on_prepared) -> RunResult:
    """`run_scenario`'s body, with one BLAS thread (`one_blas_thread`)."""
    wall0 = time.perf_counter()
    out = output_path(out) if out is not None else None  # refused before the run, not after
    plant, pipeline, reference = prepare(scenario)
    if on_prepared is not None:
        on_prepared(plant, pipeline)
    sim = scenario.sim
    n_ticks = round(sim.duration_s / sim.control_period_s)
    if sim.samples_per_tick == 1:  # one rate: every stage at the control period
        loop, steps = _loop, n_ticks
        trace_every = round(sim.trace_period_s / sim.control_period_s)
    else:                          # sensor and estimator at their own, shorter period
        loop, steps = _multirate_loop, n_ticks * sim.samples_per_tick
        trace_every = round(sim.trace_period_s / sim.estimator_period_s)
    momentum_scale = plant.momentum_scale()
    keep = None if keep_data else metrics.kept_signals(scenario)
    if reference is not None and not hasattr(reference, "update") and keep is not None:
        keep |= set(getattr(reference, "signals", None) or ()) | {"truth/omega"}
        if getattr(reference, "signals", None) is None:
            keep = None  # a reference that does not say what it reads sees everything
    reductions = Reductions(metrics.reductions(scenario))
    status, error = "ok", None
    footer = steps // trace_every <= trace.FOOTER_MAX_SAMPLES  # a long run: no footer (recording_to)
    with (trace.recording_to(out, live=live, footer=footer) if out is not None or live is not None
          else contextlib.nullcontext()) as rec:
        writer = trace.TraceWriter(rec, scenario.name, n_ticks * sim.control_period_s, plant.scene(),
                                   envelope_rows=sim.envelope_rows) if rec else None
        stream = _ChunkStream(plant, reference, reductions, writer)
        # a chunk at least every FLUSH_AFTER_S of wall time: a viewer sees the run move, and a killed
        # slow run loses at most that much of its trace
        recorder = Recorder(keep=keep, on_chunk=stream, flush_after_s=FLUSH_AFTER_S if rec else None)
        stream.recorder = recorder
        try:
            # a stage whose numbers overflow or turn invalid fails at that tick, named (StageFailed),
            # instead of printing numpy warnings and handing NaN on
            with np.errstate(over="raise", invalid="raise", divide="raise"):
                loop(plant, pipeline, recorder, steps, trace_every, sim, progress)
        except SimulationDiverged as exc:
            status, error = "diverged", str(exc)
        except StageFailed as exc:
            status, error = "error", str(exc)
        except FloatingPointError as exc:  # the plant's own read-outs overflowed: the state blew up
            status, error = "diverged", str(SimulationDiverged(plant.time, f"{exc} in the plant's read-outs"))
        recorder.flush()
        stream.finish()
        data = RunData(scenario, recorder, {slot: stage.statistics for slot, stage in pipeline.stages().items()
                                            if hasattr(stage, "statistics")},
                       plant.description(), momentum_scale, stream.reference_error, reductions=reductions)
        values, why = metrics.compute_all(data) if recorder.count > 1 else ({}, {})
        checks = metrics.evaluate_checks(scenario, values, why)
        result = RunResult(scenario.name, recorder.last_time, 0.0, status, error and error_line(error),
                           values, checks, str(out) if out else None, data if keep_data else None,
                           Trace.from_recorder(recorder) if keep_data else None)
        if writer is not None:
            result.wall_s = time.perf_counter() - wall0
            writer.finish(result.as_json() | {"stages": {slot: {"type": name, **params_dict(p)}
                                                         for slot, (name, p) in scenario.stages.items()}})
    result.wall_s = time.perf_counter() - wall0
    return result


class _ChunkStream:
    """What happens to each chunk of trace samples as the run goes: the plant's derived signals
    are added, the reference advances (`update` of a streaming reference), the metrics'
    reductions are updated and the chunk is written. A reference that needs the whole run is
    evaluated by `finish` on the kept history; a reference that fails is left out, its reason
    kept (`reference_error`) for the metrics that need it."""

    def __init__(self, plant, reference, reductions, writer):
        self.plant, self.reference, self.reductions, self.writer = plant, reference, reductions, writer
        self.recorder = None
        self.reference_error = None

    def __call__(self, chunk) -> None:
        with np.errstate(all="ignore"):  # NaN rows of a run cut short are recorded as they are
            chunk.signals.update(self.plant.derived_signals(chunk))
        self._emit(chunk)
        if self.reference is not None and hasattr(self.reference, "update") and self.reference_error is None:
            self._reference(lambda: self.reference.update(chunk))

    def finish(self) -> None:
        if self.reference is None or self.reference_error is not None:
            return
        if hasattr(self.reference, "update"):
            self._reference(self.reference.finish)
        elif self.recorder.count > 1:
            recorder = self.recorder
            self._reference(lambda: _reference_chunk(recorder.time, self.reference(recorder.time, recorder),
                                                     recorder["truth/omega"]))

    def _reference(self, evaluate) -> None:
        try:
            with np.errstate(all="ignore"):
                chunk = evaluate()
        except (ValueError, ArithmeticError) as exc:  # e.g. too short a trace to interpolate
            self.reference_error = f"the reference could not be evaluated: {exc}"
            return
        if chunk is not None:
            self._emit(chunk)
            self.recorder.keep_chunk(chunk)

    def _emit(self, chunk) -> None:
        self.reductions.update(chunk)
        if self.writer is not None:
            self.writer.write(chunk)


def _reference_chunk(times, omega_ref, omega_truth, first_row: int = 0) -> Chunk:
    """The reference's rows: `reference/omega` and the truth's error from it."""
    return Chunk(first_row, times, {"reference/omega": omega_ref, "reference/omega_error": omega_truth - omega_ref})


# Ticks between two looks for a bad state (Plant.check_state): a divergence is reported
# within this many ticks of where it happened, and the look costs a tenth of its price a tick.
CHECK_EVERY_TICKS = 10


def _loop(plant, pipeline, recorder, n_ticks, trace_every, sim, progress) -> None:
    """Tick k: the pipeline at t = k Tc, a trace sample of the stages' outputs and the truth
    every `trace_every` ticks, then Tc / dt physics steps; the truth alone at the end (always).

    The ticks run in blocks that start at a trace sample (`block_ticks`); the plant is
    checked for a bad state at the end of each block, and before a stage's failure is
    reported (a state MuJoCo reset may be what the stage failed on)."""
    steps = sim.steps_per_tick
    tc = sim.control_period_s
    block = block_ticks(trace_every, CHECK_EVERY_TICKS)
    report_every = max(1, n_ticks // 200)
    next_report = 0
    tick, advance, check = pipeline.tick, plant.stepper(steps), plant.check_state
    for first in range(0, n_ticks, block):
        t0 = first * tc
        k = first
        try:
            tick(t0, plant)
            if first % trace_every == 0:
                signals = pipeline.signals()
                signals["truth"] = plant.truth()
                recorder.sample(t0, signals)
            advance()
            for k in range(first + 1, min(first + block, n_ticks)):
                tick(k * tc, plant)
                advance()
        except (StageFailed, FloatingPointError):
            check(t0, (k - first) * steps)
            raise
        check(t0, (k + 1 - first) * steps)
        if progress is not None and first >= next_report:
            progress(first / n_ticks)
            next_report = first + report_every
    recorder.sample(sim.end_time_s, {"truth": plant.truth()})  # the final state, on the trace grid or not


def block_ticks(trace_every: int, longest: int) -> int:
    """The largest number of ticks <= `longest` that divides `trace_every`: blocks of it
    start at every trace sample."""
    return max(n for n in range(1, min(trace_every, longest) + 1) if trace_every % n == 0)


def _multirate_loop(plant, pipeline, recorder, n_samples, trace_every, sim, progress) -> None:
    """Sample j (t = j Ts, Ts = sim.estimator_period_s): the sensor and the estimator, and at
    every control instant (each `samples_per_tick`-th sample) the whole pipeline, whose command
    stays held over the control period; Ts / dt physics steps. A trace sample every
    `trace_every` samples holds the truth and the stages that ran at it: sensor and estimator at
    their rate, law and allocator only at control instants (each stage at its own rate)."""
    per_tick = sim.samples_per_tick
    steps = sim.steps_per_sample
    ts = sim.estimator_period_s
    report_every = max(1, n_samples // 200)
    tick, sense, step = pipeline.tick, pipeline.sense, plant.step
    for j in range(n_samples):
        t = j * ts
        control = j % per_tick == 0
        if control:
            tick(t, plant)
        else:
            sense(t, plant)
        if j % trace_every == 0:
            signals = pipeline.signals() if control else pipeline.sensed_signals()
            signals["truth"] = plant.truth()
            recorder.sample(t, signals)
        step(steps)
        if progress is not None and j % report_every == 0:
            progress(j / n_samples)
    recorder.sample(sim.end_time_s, {"truth": plant.truth()})  # the final state, on the trace grid or not
