"""One run between its start and its result, from its plan (testbed.run_core.plan): the
trace's recorder, chunk stream and `.rrd` writer, the loop stepped a stretch at a time, then
the metrics and checks.
"""

from __future__ import annotations

import contextlib
import time
from pathlib import Path

import numpy as np
import scipy.linalg  # noqa: F401  (loads SciPy's own OpenBLAS, so that threadpoolctl finds it)
from threadpoolctl import ThreadpoolController

from testbed import metrics
from testbed.errors import error_line
from testbed.exit_guard import os_exit_raises
from testbed.run_core.stage_contract import StageFailed
from testbed.run_core.stage_registry import params_dict
from testbed.plant import SimulationDiverged
from testbed.recording import spectra, trace
from testbed.recording.recorder import FLUSH_AFTER_S, Recorder, Trace
from testbed.recording.reductions import Reductions
from testbed.run_core.chunk_stream import ChunkStream
from testbed.run_core.loop import loop_of
from testbed.run_core.plan import RunPlan, prepare
from testbed.run_core.result import RunData, RunResult


# What stops a run before its end: the physics' divergence, a stage's failure, the plant's read-outs' overflow.
STOPPING = (SimulationDiverged, StageFailed, FloatingPointError)

_blas_controller: ThreadpoolController | None = None


def stopped_by(exc: BaseException, plant) -> tuple[str, str]:
    """(status, error) of a run that `exc` (one of `STOPPING`) stopped (`RunResult.status`)."""
    if isinstance(exc, SimulationDiverged):
        return "diverged", str(exc)
    if isinstance(exc, StageFailed):
        return "method_failed" if exc.method else "error", str(exc)
    # FloatingPointError: the plant's own read-outs overflowed, the state blew up
    return "diverged", str(SimulationDiverged(plant.time, f"{exc} in the plant's read-outs"))


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


def run_scenario(scenario, out: Path | None, progress=None, keep_data: bool = False,
                 live=None, on_prepared=None, prepared: RunPlan | None = None, stages=None) -> RunResult:
    """Run `scenario`, stream the trace to `out` (None: no file; a path `output_path` checked,
    as `testbed.run` does) and evaluate its checks; `prepared`: the run's plan
    (testbed.run_core.plan.prepare), if the caller made it to check the scenario first;
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
        if prepared is None:
            plan = prepare(scenario, stages)
        else:
            plan = prepared.with_stages(stages) if stages else prepared
        with RunInProgress(plan, out, keep_data, live, wall0) as run:
            if on_prepared is not None:
                on_prepared(plan.plant, plan.pipeline)
            run.advance(plan.timing.n_ticks, progress)
            result = run.finish()
        result.wall_s = time.perf_counter() - wall0
        return result


class RunInProgress:
    """One run between its start and its result: its plan (`plan`: plant, pipeline, reference,
    timing), the trace's recorder, chunk stream and `.rrd` writer, and how many control
    periods have run. `advance(n)` runs the next n control periods (the run's one loop),
    `finish()` records the end, computes the metrics and checks and writes the result. It is
    a context manager: the `.rrd` is renamed into place when the block ends whole, and removed
    if it ends by an exception (testbed.recording.trace.recording_to). `run_scenario` runs
    it to the end at once; `testbed.stepping.Simulation` a period at a time."""

    def __init__(self, plan: RunPlan, out=None, keep_data=False, live=None, wall0=None):
        self.wall0 = time.perf_counter() if wall0 is None else wall0
        self.plan, self.out, self.keep_data = plan, out, keep_data
        self.scenario, self.plant, self.pipeline = plan.scenario, plan.plant, plan.pipeline
        self.reference = plan.reference
        timing = plan.timing
        self.n_ticks = timing.n_ticks
        self.ticks_done = 0
        self._loop = loop_of(timing)
        self.momentum_scale = self.plant.momentum_scale()  # at t = 0
        self.reductions = Reductions(plan.reductions)
        self.status, self.error = "ok", None
        # a long run: no footer (recording_to)
        footer = timing.loop_steps // timing.trace_every <= trace.FOOTER_MAX_SAMPLES
        self._context = contextlib.ExitStack()
        rec = (self._context.enter_context(trace.recording_to(out, live=live, footer=footer))
               if out is not None or live is not None else None)
        try:
            self.writer = trace.TraceWriter(rec, self.scenario.name, timing.n_ticks * timing.control_period_s,
                                            self.plant.scene(), envelope_rows=timing.envelope_rows,
                                            source=self.scenario.source) if rec else None
        except BaseException as exc:  # no run: its partial file goes (recording_to)
            if not self._context.__exit__(type(exc), exc, exc.__traceback__):
                raise
        self.stream = ChunkStream(self.plant, self.reference, self.reductions, self.writer)
        # a chunk at least every FLUSH_AFTER_S of wall time: a viewer sees the run move, and a killed
        # slow run loses at most that much of its trace
        keep = None if keep_data or plan.kept_signals is None else set(plan.kept_signals)
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
        return self.plan.timing.time_after(self.ticks_done)

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
        timing = self.plan.timing
        per_tick = timing.samples_per_tick
        try:
            # a stage whose numbers overflow or turn invalid fails at that tick, named (StageFailed),
            # instead of printing numpy warnings and handing NaN on
            with np.errstate(over="raise", invalid="raise", divide="raise"):
                self._loop(self.plant, self.pipeline, self.recorder, start * per_tick, stop * per_tick, timing,
                           progress)
        except STOPPING as exc:
            self.stop(exc)
        if self.status == "ok":
            self.reached(stop)

    def stop(self, exc: BaseException) -> None:
        """End the run where `exc` (one of `STOPPING`) stopped it: its status and error line."""
        self.status, self.error = stopped_by(exc, self.plant)

    def reached(self, ticks: int) -> None:
        """`ticks` control periods have run (by `advance`, or by a batch of worlds in lockstep);
        after the last, the final truth sample."""
        self.ticks_done = ticks
        if ticks == self.n_ticks:  # the final state, on the trace grid or not
            self.recorder.sample(self.plan.timing.end_time_s, {"truth": self.plant.truth()})

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
        data = RunData(scenario, recorder, pipeline.statistics(), self.plant.description(),
                       self.momentum_scale, self.stream.reference_error, reductions=self.reductions)
        values, why = metrics.compute_all(data) if recorder.count > 1 else ({}, {})
        checks = metrics.evaluate_checks(scenario, values, why) + self.plan.monitors.checks(scenario, values, data)
        error = self.error
        result = RunResult(scenario.name, recorder.last_time, 0.0, self.status, error and error_line(error),
                           values, checks, str(self.out) if self.out else None, data if self.keep_data else None,
                           Trace.from_recorder(recorder) if self.keep_data else None)
        if self.writer is not None:
            result.wall_s = time.perf_counter() - self.wall0
            stages = {slot: {"type": name, **params_dict(p)} for slot, (name, p) in scenario.stages.items()}
            stages |= {slot: {"type": name} for slot, name in self.plan.given_types.items()}
            self.writer.write_spectra(spectra.compute_all(data))
            self.writer.finish(result.as_json() | {"stages": stages})
        result.wall_s = time.perf_counter() - self.wall0
        return result
