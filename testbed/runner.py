"""Run one scenario: MuJoCo truth stepped at dt, the pipeline sampled at its own period.

Per control tick k (t = k Tc): record the truth (at the trace period), run the pipeline on
the state at t, hold its command (zero-order hold) for the Tc / dt physics steps to t + Tc.
"""

from __future__ import annotations

import contextlib
import functools
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.linalg  # noqa: F401  (loads SciPy's own OpenBLAS, so that threadpoolctl finds it)
from threadpoolctl import ThreadpoolController

from testbed import metrics
from testbed.accuracy import guard as accuracy_guard
from testbed.accuracy.step_size import refuse_unresolved_step
from testbed.recording import spectra, trace
from testbed.references import registry as references_registry
from testbed.systems import registry as systems_registry
from testbed.environment import surroundings
from testbed.errors import InputError, error_line, refused_as
from testbed.exit_guard import os_exit_raises
from testbed.pipeline import Pipeline, StageContext, StageFailed, params_dict, stage_infos
from testbed.plant import SimulationDiverged
from testbed.recording.recorder import FLUSH_AFTER_S, Chunk, Recorder, Trace
from testbed.recording.reductions import Reductions
from testbed.stepping.given_stages import given_stage, type_of_given


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


# what a run ended as (RunResult.status)
STATUSES = ("ok", "diverged", "method_failed", "error")


@dataclass
class RunResult:
    """The outcome of a run (or of an `.rrd` read back): status, metrics, checks and the trace.

    status: "ok", "diverged" (MuJoCo hit a bad state), "method_failed" (a stage's method left
    the conditions it is valid in: testbed.pipeline.MethodFailed) or "error" (a stage raised or
    returned bad output); error: the one-line reason, else None; metrics: name -> value; checks: one
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


def prepare(scenario, stages: dict | None = None):
    """Build the plant, the pipeline and the reference: every design-time check happens here.
    `stages`: slot -> a Python object (or function) that takes that slot's place in the
    pipeline, checked like a plug-in (`install_stages`).

    Parameters so extreme that building from them overflows or breaks a factorisation are bad
    input, named by the part being built (model, pipeline slot, reference)."""
    scenario = surroundings.in_orbit(scenario)  # an initial state given in LVLH, in ECI
    built_from = {"model": scenario.model, "initial": scenario.initial, "orbit": scenario.orbit,
                  "environment": scenario.environment}
    with np.errstate(all="raise"), refused_as("model", params=built_from):
        plant = systems_registry.make_plant(scenario)
        plant.record_energy = scenario.stages["allocator"][0] == "none" and scenario.environment is None
        plant.initialise(scenario.initial)
        plant.surroundings = surroundings.prepare(scenario, plant)
        ctx = stage_context(scenario, plant.locked_inertia(), plant.description(), plant.actuator_state(),
                            plant.internal_momentum_body())
    refuse_unresolved_step(scenario, plant)  # the accuracy guard's step-size check, before the stages
    with np.errstate(all="raise"):
        pipeline = Pipeline.from_config(scenario.stages, ctx, plant.actuators)
    output = getattr(pipeline.allocator, "output", None)
    if output is not None and output not in plant.actuators:
        raise InputError("pipeline.allocator.type", f"{scenario.stages['allocator'][0]} commands {output}, "
                         f"which model.system {scenario.system} does not have")
    if stages:
        install_stages(pipeline, plant, stages)
    references_registry.check_system(scenario)  # after the stages: a reference describes them
    reference_params = {"reference": scenario.reference[1]} if scenario.reference else {}
    with np.errstate(all="raise"), refused_as("reference", params=reference_params):
        reference = references_registry.prepare(scenario, plant) if scenario.reference else None
    return plant, pipeline, reference


def install_stages(pipeline, plant, stages: dict) -> None:
    """Put each Python object of `stages` (slot -> object) in its slot of `pipeline`, in place
    of the configured stage, with a plug-in's output checks (testbed.stepping.given_stages)."""
    if not isinstance(stages, dict):
        raise InputError("stages", f"must be a mapping of slot -> object, got {type(stages).__name__}")
    for slot, stage_object in stages.items():
        configured = getattr(pipeline.allocator, "output", None) if slot == "allocator" else None
        pipeline.set_stage(slot, *given_stage(slot, stage_object, plant.actuators, configured))


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
                 live=None, on_prepared=None, prepared=None, stages=None) -> RunResult:
    """Run `scenario`, stream the trace to `out` (None: no file; a path `output_path` checked,
    as `testbed.run` does) and evaluate its checks; `prepared`: `prepare(scenario)`'s plant,
    pipeline and reference, if the caller built them to check the scenario first;
    `keep_data` keeps the whole trace and what the metrics saw in the result (otherwise only the
    signals the metrics need are kept: memory does not grow with the run for metrics that are
    running reductions); `live`: a viewer (testbed.recording.live_view.ViewerStream) the trace is also
    streamed to as it goes, never waited for; the file and the viewer get a chunk at least
    every FLUSH_AFTER_S of wall time; `progress(fraction)` is called about 200 times;
    `on_prepared(plant, pipeline)` sees the built plant and stages before the first step (a
    campaign reads back what the case runs with); `stages`: slot -> a Python object that
    takes the slot's place (`prepare`). os._exit called by a plug-in's code raises
    (testbed.exit_guard), so that a stage that calls it fails the run."""
    with one_blas_thread(), os_exit_raises():
        wall0 = time.perf_counter()
        with RunInProgress(scenario, out, keep_data, live, prepared, stages, wall0) as run:
            if on_prepared is not None:
                on_prepared(run.plant, run.pipeline)
            run.advance(run.n_ticks, progress)
            result = run.finish()
        result.wall_s = time.perf_counter() - wall0
        return result


class RunInProgress:
    """One run between its start and its result: the plant, pipeline and reference
    (`prepare`), the trace's recorder, chunk stream and `.rrd` writer, and how many control
    periods have run. `advance(n)` runs the next n control periods (the runner's one loop),
    `finish()` records the end, computes the metrics and checks and writes the result. It is
    a context manager: the `.rrd` is renamed into place when the block ends whole, and removed
    if it ends by an exception (testbed.recording.trace.recording_to). `run_scenario` runs
    it to the end at once; `testbed.stepping.Simulation` a period at a time."""

    def __init__(self, scenario, out=None, keep_data=False, live=None, prepared=None, stages=None,
                 wall0=None):
        self.wall0 = time.perf_counter() if wall0 is None else wall0
        self.scenario, self.out = scenario, out
        plant, pipeline, reference = prepared if prepared is not None else prepare(scenario, stages)
        if prepared is not None and stages:
            install_stages(pipeline, plant, stages)
        self.plant, self.pipeline, self.reference = plant, pipeline, reference
        self.stage_types = {slot: type_of_given(pipeline.stages()[slot]) for slot in stages or {}}
        sim = scenario.sim
        self.n_ticks = round(sim.duration_s / sim.control_period_s)
        self.ticks_done = 0
        if sim.samples_per_tick == 1:  # one rate: every stage at the control period
            self._loop, self._per_tick = _loop, 1
            self._trace_every = round(sim.trace_period_s / sim.control_period_s)
        else:                          # sensor and estimator at their own, shorter period
            self._loop, self._per_tick = _multirate_loop, sim.samples_per_tick
            self._trace_every = round(sim.trace_period_s / sim.estimator_period_s)
        self.momentum_scale = plant.momentum_scale()
        keep = None if keep_data else metrics.kept_signals(scenario)
        if reference is not None and not hasattr(reference, "update") and keep is not None:
            keep |= set(getattr(reference, "signals", None) or ()) | {"truth/omega"}
            if getattr(reference, "signals", None) is None:
                keep = None  # a reference that does not say what it reads sees everything
        self.keep_data = keep_data
        self.monitors = accuracy_guard.Monitors(scenario, plant, pipeline)  # the accuracy guard's
        self.reductions = Reductions(metrics.reductions(scenario) + self.monitors.reductions())
        self.status, self.error = "ok", None
        steps = self.n_ticks * self._per_tick
        footer = steps // self._trace_every <= trace.FOOTER_MAX_SAMPLES  # a long run: no footer (recording_to)
        self._context = contextlib.ExitStack()
        rec = (self._context.enter_context(trace.recording_to(out, live=live, footer=footer))
               if out is not None or live is not None else None)
        try:
            self.writer = trace.TraceWriter(rec, scenario.name, self.n_ticks * sim.control_period_s, plant.scene(),
                                            envelope_rows=sim.envelope_rows, source=scenario.source) if rec else None
        except BaseException as exc:  # no run: its partial file goes (recording_to)
            if not self._context.__exit__(type(exc), exc, exc.__traceback__):
                raise
        self.stream = _ChunkStream(plant, reference, self.reductions, self.writer)
        # a chunk at least every FLUSH_AFTER_S of wall time: a viewer sees the run move, and a killed
        # slow run loses at most that much of its trace
        self.recorder = Recorder(keep=keep, on_chunk=self.stream, flush_after_s=FLUSH_AFTER_S if rec else None)

    def __enter__(self) -> "RunInProgress":
        return self

    def __exit__(self, *exc_info) -> bool:
        return self._context.__exit__(*exc_info)

    @property
    def time(self) -> float:
        """The run's time [s] after the periods run: ticks_done control periods on the grid, exact
        (MuJoCo's clock adds dt at each step and drifts by round-off, 1e-11 s over 1000 steps);
        the plant's clock once the run has diverged or failed within a period."""
        if self.status != "ok":
            return self.plant.time
        sim = self.scenario.sim
        if self._per_tick == 1:
            return self.ticks_done * sim.control_period_s
        return self.ticks_done * self._per_tick * sim.estimator_period_s

    @property
    def running(self) -> bool:
        """Whether control periods are left to run and the run has neither diverged nor failed."""
        return self.status == "ok" and self.ticks_done < self.n_ticks

    def advance(self, ticks: int, progress=None) -> None:
        """Run the next `ticks` control periods (fewer at the end of the run), stopping at a
        divergence or a stage's failure (`status`, `error`); after the last period, the
        final truth sample."""
        if not self.running:
            return
        start = self.ticks_done
        stop = min(start + ticks, self.n_ticks)
        sim = self.scenario.sim
        try:
            # a stage whose numbers overflow or turn invalid fails at that tick, named (StageFailed),
            # instead of printing numpy warnings and handing NaN on
            with np.errstate(over="raise", invalid="raise", divide="raise"):
                self._loop(self.plant, self.pipeline, self.recorder, start * self._per_tick,
                           stop * self._per_tick, self._trace_every, sim, progress, self.n_ticks * self._per_tick)
        except SimulationDiverged as exc:
            self.status, self.error = "diverged", str(exc)
        except StageFailed as exc:
            self.status, self.error = "method_failed" if exc.method else "error", str(exc)
        except FloatingPointError as exc:  # the plant's own read-outs overflowed: the state blew up
            self.status, self.error = "diverged", str(SimulationDiverged(self.plant.time,
                                                                         f"{exc} in the plant's read-outs"))
        if self.status == "ok":
            self.ticks_done = stop
            if stop == self.n_ticks:  # the final state, on the trace grid or not
                self.recorder.sample(sim.end_time_s, {"truth": self.plant.truth()})

    def finish(self) -> RunResult:
        """The run's result: the trace flushed, the reference finished, the metrics and checks
        of what ran (the whole run, or the periods run so far), written into the `.rrd`."""
        scenario, recorder, pipeline = self.scenario, self.recorder, self.pipeline
        recorder.flush()
        if self.status == "ok" and 0 < self.ticks_done < self.n_ticks and self.time > recorder.last_time:
            # closed before its end: the truth where it stopped, so the periods after the last trace
            # sample count (as the end of a whole run records its final state)
            recorder.sample(self.time, {"truth": self.plant.truth()})
            recorder.flush()
        self.stream.finish(recorder)
        data = RunData(scenario, recorder, {slot: stage.statistics for slot, stage in pipeline.stages().items()
                                            if hasattr(stage, "statistics")},
                       self.plant.description(), self.momentum_scale, self.stream.reference_error,
                       reductions=self.reductions)
        values, why = metrics.compute_all(data) if recorder.count > 1 else ({}, {})
        checks = metrics.evaluate_checks(scenario, values, why) + self.monitors.checks(scenario, values, data)
        error = self.error
        result = RunResult(scenario.name, recorder.last_time, 0.0, self.status, error and error_line(error),
                           values, checks, str(self.out) if self.out else None, data if self.keep_data else None,
                           Trace.from_recorder(recorder) if self.keep_data else None)
        if self.writer is not None:
            result.wall_s = time.perf_counter() - self.wall0
            stages = {slot: {"type": name, **params_dict(p)} for slot, (name, p) in scenario.stages.items()}
            stages |= {slot: {"type": name} for slot, name in self.stage_types.items()}
            self.writer.write_spectra(spectra.compute_all(data))
            self.writer.finish(result.as_json() | {"stages": stages})
        result.wall_s = time.perf_counter() - self.wall0
        return result


class _ChunkStream:
    """What happens to each chunk of trace samples as the run goes: the plant's derived signals
    are added, the reference advances (`update` of a streaming reference), the metrics'
    reductions are updated and the chunk is written; the reference's rows go back to the
    recorder to keep. A reference that needs the whole run is evaluated by `finish` on the kept
    history; a reference that fails is left out, its reason kept (`reference_error`) for the
    metrics that need it."""

    def __init__(self, plant, reference, reductions, writer):
        self.plant, self.reference, self.reductions, self.writer = plant, reference, reductions, writer
        self.reference_error = None

    def __call__(self, chunk) -> list[Chunk]:
        with np.errstate(all="ignore"):  # NaN rows of a run cut short are recorded as they are
            chunk.signals.update(self.plant.derived_signals(chunk))
        self._emit(chunk)
        if self.reference is not None and hasattr(self.reference, "update") and self.reference_error is None:
            return self._reference(lambda: self.reference.update(chunk))
        return []

    def finish(self, recorder) -> None:
        """The reference's last rows (a streaming one's), or all of them (one that needs the whole
        run, from the recorder's kept history), into `recorder`."""
        if self.reference is None or self.reference_error is not None:
            return
        if hasattr(self.reference, "update"):
            rows = self._reference(self.reference.finish)
        elif recorder.count > 1:
            rows = self._reference(lambda: _reference_chunk(recorder.time, self.reference(recorder.time, recorder),
                                                            recorder["truth/omega"]))
        else:
            rows = []
        for chunk in rows:
            recorder.keep_chunk(chunk)

    def _reference(self, evaluate) -> list[Chunk]:
        """The chunk `evaluate()` gives, written ([] if none, or if the reference failed)."""
        try:
            with np.errstate(all="ignore"):
                chunk = evaluate()
        except (ValueError, ArithmeticError) as exc:  # e.g. too short a trace to interpolate
            self.reference_error = f"the reference could not be evaluated: {exc}"
            return []
        if chunk is None:
            return []
        self._emit(chunk)
        return [chunk]

    def _emit(self, chunk) -> None:
        # a metric's running reduction under- or overflows to a value that is not finite, which fails
        # its checks with the reason (metrics.compute_all): not a numpy warning, nor the run's divergence
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # numpy's nan-reductions of an all-NaN window
            self.reductions.update(chunk)
        if self.writer is not None:
            self.writer.write(chunk)


def _reference_chunk(times, omega_ref, omega_truth, first_row: int = 0) -> Chunk:
    """The reference's rows: `reference/omega` and the truth's error from it."""
    return Chunk(first_row, times, {"reference/omega": omega_ref, "reference/omega_error": omega_truth - omega_ref})


# Ticks between two looks for a bad state (Plant.check_state): a divergence is reported
# within this many ticks of where it happened, and the look costs a tenth of its price a tick.
CHECK_EVERY_TICKS = 10


def _loop(plant, pipeline, recorder, start, stop, trace_every, sim, progress, n_ticks) -> None:
    """Ticks k = start .. stop - 1 of the run's `n_ticks`: the pipeline at t = k Tc, a trace
    sample of the stages' outputs and the truth every `trace_every` ticks, then Tc / dt physics
    steps.

    The ticks run in blocks that start at a trace sample (`block_ticks`; a range that starts
    between two is first run to the next block's start); the plant is checked for a bad state
    at the end of each block, and before a stage's failure is reported (a state MuJoCo reset
    may be what the stage failed on)."""
    steps = sim.steps_per_tick
    tc = sim.control_period_s
    block = block_ticks(trace_every, CHECK_EVERY_TICKS)
    report_every = max(1, n_ticks // 200)
    next_report = start
    tick, advance, check = pipeline.tick, plant.stepper(steps), plant.check_state
    first = start
    while first < stop:
        last = min(first + block - first % block, stop)  # the end of the block `first` is in
        t0 = first * tc
        k = first
        try:
            tick(t0, plant)
            if first % trace_every == 0:
                signals = pipeline.signals()
                signals["truth"] = plant.truth()
                recorder.sample(t0, signals)
            advance()
            for k in range(first + 1, last):
                tick(k * tc, plant)
                advance()
        except (StageFailed, FloatingPointError):
            check(t0, (k - first) * steps)
            raise
        check(t0, (k + 1 - first) * steps)
        if progress is not None and first >= next_report:
            progress(first / n_ticks)
            next_report = first + report_every
        first = last


@functools.lru_cache(maxsize=64)  # a stepped run asks at every period
def block_ticks(trace_every: int, longest: int) -> int:
    """The largest number of ticks <= `longest` that divides `trace_every`: blocks of it
    start at every trace sample."""
    return max(n for n in range(1, min(trace_every, longest) + 1) if trace_every % n == 0)


def _multirate_loop(plant, pipeline, recorder, start, stop, trace_every, sim, progress, n_samples) -> None:
    """Samples j = start .. stop - 1 of the run's `n_samples` (t = j Ts, Ts =
    sim.estimator_period_s): the sensor and the estimator, and at every control instant (each
    `samples_per_tick`-th sample) the whole pipeline, whose command stays held over the control
    period; Ts / dt physics steps. A trace sample every `trace_every` samples holds the truth
    and the stages that ran at it: sensor and estimator at their rate, law and allocator only
    at control instants (each stage at its own rate)."""
    per_tick = sim.samples_per_tick
    steps = sim.steps_per_sample
    ts = sim.estimator_period_s
    report_every = max(1, n_samples // 200)
    tick, sense, step = pipeline.tick, pipeline.sense, plant.step
    for j in range(start, stop):
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
