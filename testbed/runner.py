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

from testbed import metrics, references_registry, systems_registry, trace
from testbed.errors import InputError
from testbed.pipeline import Pipeline, StageContext, StageFailed, params_dict, stage_infos
from testbed.plant import SimulationDiverged
from testbed.recorder import Recorder, Trace


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
    with np.errstate(all="raise"), _refused_as("model"):
        plant = systems_registry.make_plant(scenario)
        plant.record_energy = scenario.stages["allocator"][0] == "none"
        plant.initialise(scenario.initial)
        ctx = stage_context(scenario, plant.locked_inertia(), plant.description(), plant.actuator_state(),
                            plant.internal_momentum_body())
    with np.errstate(all="raise"):
        pipeline = Pipeline.from_config(scenario.stages, ctx, plant.actuators)
    output = getattr(pipeline.allocator, "output", None)
    if output is not None and output not in plant.actuators:
        raise InputError("pipeline.allocator.type", f"{scenario.stages['allocator'][0]} commands {output}, "
                         f"which model.system {scenario.system} does not have")
    references_registry.check_system(scenario)  # after the stages: a reference describes them
    with np.errstate(all="raise"), _refused_as("reference"):
        reference = references_registry.prepare(scenario, plant) if scenario.reference else None
    return plant, pipeline, reference


@contextlib.contextmanager
def _refused_as(field: str):
    """Arithmetic and linear-algebra failures while building from parameters: InputError(field)."""
    try:
        yield
    except (ArithmeticError, np.linalg.LinAlgError) as exc:
        raise InputError(field, f"its parameters cannot be built: {type(exc).__name__}: {exc}") from None


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
                        stages=stage_infos(scenario.stages), actuators=dict(actuators or {}))


def run_scenario(scenario, out: Path | None, progress=None, keep_data: bool = False) -> RunResult:
    """Run `scenario`, write the trace to `out` (None: no file) and evaluate its checks;
    `keep_data` keeps the trace and what the metrics saw in the result; `progress(fraction)`
    is called about 200 times."""
    wall0 = time.perf_counter()
    out = trace.output_path(out) if out is not None else None  # refused before the run, not after
    plant, pipeline, reference = prepare(scenario)
    sim = scenario.sim
    n_ticks = round(sim.duration_s / sim.control_period_s)
    if sim.samples_per_tick == 1:  # one rate: every stage at the control period
        loop, steps = _loop, n_ticks
        trace_every = round(sim.trace_period_s / sim.control_period_s)
    else:                          # sensor and estimator at their own, shorter period
        loop, steps = _multirate_loop, n_ticks * sim.samples_per_tick
        trace_every = round(sim.trace_period_s / sim.estimator_period_s)
    recorder = Recorder(-(-steps // trace_every) + 1)  # the samples on the grid and the final state
    momentum_scale = plant.momentum_scale()
    status, error = "ok", None
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
    if recorder.count:
        for key, values in plant.derived_signals(recorder).items():
            recorder.add_series(key, values)
    data = RunData(scenario, recorder, {slot: stage.statistics for slot, stage in pipeline.stages().items()
                                        if hasattr(stage, "statistics")},
                   plant.description(), momentum_scale)
    if reference is not None and recorder.count > 1:
        try:
            with np.errstate(all="ignore"):
                omega_ref = reference(recorder.time, recorder)
            recorder.add_series("reference/omega", omega_ref)
            recorder.add_series("reference/omega_error", recorder["truth/omega"] - omega_ref)
        except (ValueError, ArithmeticError) as exc:  # e.g. too short a trace to interpolate
            data.reference_error = f"the reference could not be evaluated: {exc}"
    values, why = metrics.compute_all(data) if recorder.count > 1 else ({}, {})
    checks = metrics.evaluate_checks(scenario, values, why)
    result = RunResult(scenario.name, recorder.time[-1] if recorder.count else 0.0, 0.0, status, error,
                       values, checks, str(out) if out else None, data if keep_data else None,
                       Trace.from_recorder(recorder) if keep_data else None)
    if out is not None:
        result.wall_s = time.perf_counter() - wall0
        summary = result.as_json() | {"stages": {slot: {"type": name, **params_dict(p)}
                                                 for slot, (name, p) in scenario.stages.items()}}
        trace.write_rrd(Path(out), recorder, summary, plant.scene())
    result.wall_s = time.perf_counter() - wall0
    return result


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
    recorder.sample(n_ticks * tc, {"truth": plant.truth()})  # the final state, on the trace grid or not


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
    recorder.sample(n_samples * ts, {"truth": plant.truth()})  # the final state, on the trace grid or not
