"""A run driven a control period at a time: `Simulation(scenario)`, `reset(seed)`, `step()`,
the truth and the stages' outputs read between steps, `close()` for the result.

It starts from the run's plan (testbed.run_core.plan) and steps the run's own loop
(testbed.run_core.in_progress.RunInProgress), so a run stepped to its end
with the built-in stages is the run `testbed.run` makes, bit for bit. docs/stepping.md.
"""

from __future__ import annotations

import contextlib
import os
import time
from pathlib import Path

import numpy as np

from testbed.errors import InputError
from testbed.exit_guard import os_exit_raises
from testbed.recording.output_paths import CheckedPath, output_path
from testbed.run_core.in_progress import RunInProgress, one_blas_thread
from testbed.run_core.plan import prepare
from testbed.run_core.result import RunResult
from testbed.run_core.stage_contract import SLOTS, StageFailed
from testbed.scenario.loading import Scenario
from testbed.stepping.episode_source import EpisodeSource
from testbed.stepping.given_stages import SLOT_METHODS, GivenOutput, output_check


class Simulation:
    """One scenario, stepped by the caller.

        sim = testbed.Simulation("reorient_minimax")        # built and at t = 0
        while sim.running:
            sim.step()                                       # one control period
            sim.truth()["omega"], sim.outputs["law"]["torque"]
        result = sim.close()                                 # the RunResult testbed.run gives

    `scenario`: a name or path (with `overrides`), a raw mapping, or a loaded `Scenario`;
    `stages`: slot -> a Python object in that slot's place (as `testbed.run(stages=)`);
    `out`: a path the trace of each episode is written to as an `.rrd` (None: no file; each
    `reset` starts the file again); `keep_trace`: keep every signal for `close()`'s result.
    `seed`: as `reset(seed)`, for the first episode.

    While a Simulation is open, in the thread that opened it, os._exit raises (as in any run:
    testbed.exit_guard, so that a stage calling it fails the run) and the process's BLAS runs
    on one thread (testbed.run_core.in_progress.one_blas_thread); `close()` (or the `with` block's end)
    restores both. Step it from the thread that made it."""

    def __init__(self, scenario: Scenario | str | Path | dict, overrides: list[str] = (), *,
                 stages: dict | None = None, out: str | Path | None = None, keep_trace: bool = True,
                 seed: int | None = None):
        self._episodes = EpisodeSource(scenario, overrides)
        if out is not None and not isinstance(out, (str, os.PathLike)):
            raise InputError("out", f"must be a file path (str or pathlib.Path) or None, got {type(out).__name__}")
        self._out = out.path if isinstance(out, CheckedPath) else output_path(out) if out is not None else None
        if not isinstance(keep_trace, bool):
            raise InputError("keep_trace", f"must be True or False, got {keep_trace!r}")
        self._stages, self._keep_trace = stages, keep_trace
        self._run: RunInProgress | None = None
        self._closed = False  # the episode's result is made: it is read, no longer stepped
        self._guards = None  # one BLAS thread and os._exit raising, while open (as in_progress.run_scenario)
        self.result: RunResult | None = None  # the last episode's, once it is closed
        try:
            self.reset(seed)
        except BaseException:
            self.close()  # nothing built: the guards are lifted again
            raise

    # --- episodes ------------------------------------------------------------------------
    def reset(self, seed: int | None = None) -> None:
        """Start the run again from t = 0 with a freshly built plant and stages; with a `seed`,
        the scenario's campaign dispersions (its `sweep.dispersions`) drawn from that case seed
        (testbed.campaign.cases.seeded_scenario: the grid and `random:` fields keep their base
        values), else the scenario as it is. The episode before is closed first."""
        self._close_run()
        scenario = self._episodes.scenario(seed)
        if self._guards is None:
            self._guards = contextlib.ExitStack()
            self._guards.enter_context(one_blas_thread())
            self._guards.enter_context(os_exit_raises())
        wall0 = time.perf_counter()
        self._run = RunInProgress(prepare(scenario, self._stages, stepped=True), self._out, self._keep_trace, wall0=wall0)
        self._closed, self.result = False, None

    def step(self, command: dict | None = None) -> dict:
        """Run one control period (sensor, estimator, law, allocator, then the physics to the
        next control instant; several sensor samples if the estimator runs faster) and return
        the stages' outputs (`outputs`). `command`: slot -> that slot's output for this period
        in place of its stage's (`{"law": {"torque": tau}}` for the built-in allocator to
        steer, `{"allocator": {"gimbal_rates": rates}}` straight to the plant), checked like a
        plug-in's output (a bad one raises InputError and runs nothing). A run that has ended
        (`running` false) is not stepped."""
        run = self._open_episode()
        if command is None:
            run.advance(1)
            return self.outputs
        given = self._given(command)
        pipeline = run.pipeline
        stages = pipeline.stages()
        saved = {slot: (stages[slot], pipeline.checks.get(slot), pipeline.declared[slot]) for slot in given}
        for slot, stage in given.items():
            pipeline.set_stage(slot, stage, None)
        try:
            run.advance(1)
        finally:
            for slot, (stage, check, declared) in saved.items():
                pipeline.set_stage(slot, stage, check, declared)
        return self.outputs

    def close(self) -> RunResult | None:
        """End the episode: its result (metrics and checks of the periods run, the `.rrd`
        written whole), also kept as `result`; the BLAS thread limit and the os._exit guard are
        lifted. What the episode ended with stays readable (`truth()`, `outputs`, `ticks`...)."""
        self._close_run()
        if self._guards is not None:
            self._guards.close()
            self._guards = None
        return self.result

    def __enter__(self) -> "Simulation":
        return self

    def __exit__(self, *exc_info) -> None:
        if exc_info[0] is not None and self._run is not None and not self._closed:
            self._closed = True  # the .rrd of a broken episode is removed
            self._run.__exit__(*exc_info)
        self.close()

    # --- what can be read between steps -------------------------------------------------------
    @property
    def scenario(self) -> Scenario:
        """The scenario of this episode (its dispersions drawn)."""
        return self._episode().scenario

    @property
    def episodes(self) -> EpisodeSource:
        """Where the episodes' scenarios are drawn from (the scenario for a seed)."""
        return self._episodes

    @property
    def disperses(self) -> bool:
        """Whether a seed draws anything: the scenario has a `sweep.dispersions` block."""
        return self._episodes.disperses

    @property
    def plant(self):
        """The plant (testbed.plant.Plant): its read-outs (`omega()`, `quat()`, ...) are the truth."""
        return self._episode().plant

    @property
    def pipeline(self):
        return self._episode().pipeline

    @property
    def plan(self):
        """The episode's run plan (testbed.run_core.plan.RunPlan: plant, pipeline, timing, ...)."""
        return self._episode().plan

    @property
    def time(self) -> float:
        """The simulated time now [s]: the start of the next control period, on the grid exactly
        (ticks x sim.control_period_s; `plant.time`, MuJoCo's clock, drifts by round-off)."""
        return self._episode().time

    @property
    def ticks(self) -> int:
        """Control periods run in this episode."""
        return self._episode().ticks_done

    @property
    def n_ticks(self) -> int:
        """Control periods in the whole scenario (sim.duration_s / sim.control_period_s)."""
        return self._episode().n_ticks

    @property
    def running(self) -> bool:
        """Periods are left, and the run has neither diverged nor had a stage fail."""
        return self._episode().running

    @property
    def status(self) -> str:
        """"ok", "diverged", "method_failed" or "error", as `RunResult.status`."""
        return self._episode().status

    @property
    def error(self) -> str | None:
        return self._episode().error

    def truth(self) -> dict[str, np.ndarray]:
        """The true state now, as the trace records it (`truth/*`: omega, quat, ...)."""
        return self._episode().plant.truth()

    @property
    def outputs(self) -> dict[str, dict]:
        """slot -> the stage's last output (the `sensor/*`, `estimator/*`, `law/*`,
        `allocator/*` signals of the last control instant)."""
        return self._episode().pipeline.signals()

    # --- inside ------------------------------------------------------------------------------
    def _episode(self) -> RunInProgress:
        """The episode under way, or the last one once closed (still readable)."""
        if self._run is None:
            raise RuntimeError("this Simulation has no episode: reset() starts one")
        return self._run

    def _open_episode(self) -> RunInProgress:
        if self._closed:
            raise RuntimeError("this Simulation's episode is closed: reset() starts a new one")
        return self._episode()

    def _close_run(self) -> None:
        if self._run is not None and not self._closed:
            self._closed = True
            with self._run:
                self.result = self._run.finish()

    def _given(self, command) -> dict:
        """slot -> a stage returning the caller's output for this step, the output checked first."""
        if not isinstance(command, dict) or not command:
            raise InputError("command", f"must be a mapping of slot -> output dict, got {command!r}")
        run = self._run
        actuators = run.plant.actuators
        given = {}
        for slot, output in command.items():
            if slot not in SLOT_METHODS:
                raise InputError("command", f"unknown slot {slot!r} (known: {', '.join(SLOTS)})")
            if not isinstance(output, dict):
                raise InputError(f"command.{slot}", f"must be a dict of arrays, got {type(output).__name__}")
            key = next((k for k in output if k in actuators), None) if slot == "allocator" else None
            check = output_check(slot, "given", actuators, key, where=f"command.{slot}")
            try:
                check(self.time, output)
            except StageFailed as exc:
                raise InputError(f"command.{slot}", str(exc).split(": ", 1)[-1]) from None
            given[slot] = GivenOutput(slot, output, key)
        return given


