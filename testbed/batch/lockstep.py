"""Many worlds stepped in lockstep: one control tick of the stages for all of them on (N, ...)
arrays, then each world's physics, tick by tick (docs/architecture.md "Many worlds").

Each world is a whole run of its own plan (testbed.run_core.plan), its own model (a campaign's
dispersions may differ from world to world), recorder, reductions and result: a `Batch` only
shares the stages' Python cost, through their batched forms (testbed.batch.stage_forms). A
world that diverges or fails leaves the batch with its row and trace as a single run keeps them;
its batch-mates go on.
"""

from __future__ import annotations

import numpy as np

from testbed.batch.batch_recorder import BatchRecorder
from testbed.batch.physics_threads import PhysicsThreads
from testbed.batch.plant_group import group_of
from testbed.batch.stage_forms import WorldsFailed, declared_alike, forms_of, tick_slots
from testbed.run_core.in_progress import STOPPING, RunInProgress, one_blas_thread
from testbed.run_core.loop import CHECK_EVERY_TICKS, block_ticks
from testbed.run_core.plan import RunPlan
from testbed.run_core.stage_contract import StageFailed

SIGNAL_GROUPS = ("sensor", "estimator", "law", "allocator")


class Batch:
    """N runs of plans sharing one timing, stepped together: `advance(ticks)` runs the next control
    periods of every world still going, `finish()` gives each world's `RunResult` (as
    `run_scenario` would: same status, metrics and checks; bit for bit where every slot runs per
    world, to the batched forms' round-off otherwise). `outs`: each world's `.rrd` path or None."""

    def __init__(self, plans: list[RunPlan], outs: list | None = None, keep_data: bool = False,
                 threads: int = 1):
        if not plans:
            raise ValueError("a batch needs at least one world")
        timing = plans[0].timing
        for plan in plans[1:]:
            if plan.timing != timing:
                raise ValueError(f"worlds of a batch share one timing: {plan.scenario.name} differs from "
                                 f"{plans[0].scenario.name} (batch them apart)")
        if timing.multirate:
            raise ValueError("a batch steps one rate: sensors faster than the law run as single runs")
        self.timing = timing
        outs = list(outs) if outs is not None else [None] * len(plans)
        self.runs = [RunInProgress(plan, out, keep_data) for plan, out in zip(plans, outs)]
        pipelines = [plan.pipeline for plan in plans]
        self.declared = {slot: declared_alike(pipelines, slot) for slot in SIGNAL_GROUPS}
        self.forms = forms_of(pipelines)
        self.live = np.arange(len(plans))  # the worlds still going, in order
        self.pipelines = pipelines
        self.group = group_of([plan.plant for plan in plans], timing.steps_per_tick)
        self.physics = PhysicsThreads(threads)
        self.recorder = BatchRecorder([run.recorder for run in self.runs])
        self.outputs = {group: {} for group in SIGNAL_GROUPS}  # the last tick's, rows of the live worlds
        self.ticks_done = 0

    def __enter__(self) -> "Batch":
        return self

    def __exit__(self, *exc_info) -> bool:
        """Close every world's trace (removed if the block ends by an exception)."""
        self.physics.close()
        result = False
        for run in self.runs:
            result = run.__exit__(*exc_info) or result
        return result

    @property
    def running(self) -> bool:
        return len(self.live) > 0 and self.ticks_done < self.timing.n_ticks

    def advance(self, ticks: int) -> None:
        """Run the next `ticks` control periods of every live world (fewer at the end of the run)."""
        if not self.running:
            return
        stop = min(self.ticks_done + ticks, self.timing.n_ticks)
        with one_blas_thread(), np.errstate(over="raise", invalid="raise", divide="raise"):
            first = self.ticks_done
            block = block_ticks(self.timing.trace_every, CHECK_EVERY_TICKS)
            while first < stop and len(self.live):
                last = min(first + block - first % block, stop)
                self._block(first, last)
                first = last
        self.ticks_done = stop
        if stop == self.timing.n_ticks:
            self.recorder.flush()
            for world in self.live.tolist():
                self._ended(world, None)

    def _block(self, first: int, last: int) -> None:
        """Ticks first .. last - 1, a trace sample at the first when it falls on the trace grid; every
        live world's physics checked for a bad state at the end."""
        timing = self.timing
        tc, steps = timing.control_period_s, timing.steps_per_tick
        for k in range(first, last):
            t = k * tc
            self._tick(t, first)
            if k == first and k % timing.trace_every == 0:
                self._sample(t)
            self.physics.run(self.group.step_calls())
        self._leave(self.group.check_state(first * tc, (last - first) * steps), first)

    def _tick(self, t: float, block_start: int) -> None:
        """The four slots at time t on the live worlds, then each world's command to its plant."""
        failed = tick_slots(t, self.forms, self.group, self.declared, self.outputs,
                            lambda _, call: self._slot(t, block_start, call),
                            lambda: [self.pipelines[world] for world in self.live.tolist()])
        self._leave(failed, block_start, t)

    def _slot(self, t: float, block_start: int, call):
        """A slot's outputs (or the plants' read-outs) for the live worlds; the worlds it failed
        leave the batch."""
        try:
            return call()
        except WorldsFailed as exc:
            self._leave(exc.failures, block_start, t)
            if isinstance(exc.outputs, dict):
                return {key: values[self._kept] for key, values in exc.outputs.items()}
            return exc.outputs[self._kept]

    def _sample(self, t: float) -> None:
        """A trace sample at t: the stages' last outputs and each live world's truth."""
        truth = self._slot(t, round(t / self.timing.control_period_s), self.group.truth)
        groups = {group: self.outputs[group] for group in SIGNAL_GROUPS if self.outputs[group]}
        groups["truth"] = truth
        self.recorder.sample(t, groups, self.live)

    def _leave(self, failed: dict, block_start: int, t: float | None = None) -> None:
        """The worlds at rows `failed` (row -> what stopped it) leave the batch: a stage's failure is
        reported as the physics' divergence when the physics met a bad state first (as `run_ticks`
        does), their traces flushed, their stages' state written back."""
        self._kept = None
        if not failed:
            return
        timing = self.timing
        self.recorder.flush()
        live = self.live.tolist()
        if t is not None:
            steps = round(t / timing.control_period_s - block_start) * timing.steps_per_tick
            diverged = self.group.check_state(block_start * timing.control_period_s, steps)
            failed = {row: diverged.get(row, exc) if isinstance(exc, StageFailed) else exc
                      for row, exc in failed.items()}
        for row, exc in sorted(failed.items()):
            for form in (*self.forms.values(), self.group):
                form.settle(row)
            self._ended(live[row], exc)
        kept = np.array([row for row in range(len(live)) if row not in failed], dtype=int)
        for form in (*self.forms.values(), self.group):
            form.keep(kept)
        for group in SIGNAL_GROUPS:
            self.outputs[group] = {key: values[kept] for key, values in self.outputs[group].items()}
        self.live = self.live[kept]
        self._kept = kept

    def _ended(self, world: int, exc: BaseException | None) -> None:
        """World `world` ended: stopped by `exc` (one of STOPPING), or at the end of the run (None)."""
        run = self.runs[world]
        if exc is None:
            for row, live_world in enumerate(self.live.tolist()):
                if live_world == world:
                    for form in (*self.forms.values(), self.group):
                        form.settle(row)
            run.reached(self.timing.n_ticks)
        else:
            assert isinstance(exc, STOPPING), exc
            run.ticks_done = self.ticks_done
            run.stop(exc)

    def finish(self) -> list:
        """Each world's RunResult, in the order of the plans (a world still going, its stages' and
        plant's state written back first: its result is that of a run closed where it stopped)."""
        if self.running:
            self.recorder.flush()
            for row, world in enumerate(self.live.tolist()):
                for form in (*self.forms.values(), self.group):
                    form.settle(row)
                self.runs[world].ticks_done = self.ticks_done
        return [run.finish() for run in self.runs]


def run_batch(plans: list[RunPlan], outs: list | None = None, keep_data: bool = False, threads: int = 1) -> list:
    """Run the plans' worlds in lockstep to their end: each world's RunResult, in order (`Batch`;
    `threads`: the physics' threads, testbed.batch.physics_threads)."""
    with Batch(plans, outs, keep_data, threads) as batch:
        batch.advance(batch.timing.n_ticks)
        return batch.finish()
