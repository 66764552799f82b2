"""Many worlds stepped a control period at a time by their caller, each world restarted on its
own (docs/stepping.md "Vector environments"): what a vector environment steps.

A world is one run's plan (testbed.run_core.plan.prepare(..., stepped=True)) at its own clock.
The worlds that started together form a cohort, which shares one clock and steps its slots
through their batched forms (testbed.batch.stage_forms: a slot without one runs per world), as a
`testbed.batch.Batch` does. A restarted world leaves its cohort, and the worlds restarted
together form a new one at t = 0. Each step may give any slot's output for every world, as
`testbed.stepping.Simulation.step(command)` does for one: the slot's stage is then not run.
A world that diverges or whose stage fails stops where it failed (`status`, `error`, as
`RunResult`), and its cohort-mates go on. No trace is kept: a world's read-outs are its plant's.
"""

from __future__ import annotations

import numpy as np

from testbed.batch.physics_threads import PhysicsThreads
from testbed.batch.plant_group import group_of
from testbed.batch.stage_forms import WorldsFailed, declared_alike, forms_of, tick_slots
from testbed.run_core.in_progress import STOPPING, one_blas_thread, stopped_by
from testbed.run_core.plan import RunPlan
from testbed.run_core.stage_contract import SLOTS


class Cohort:
    """The worlds `rows` (indices among the batch's N, increasing) of `plans`, started together:
    one clock (`ticks` control periods run), each slot's form over them and their plants' group."""

    def __init__(self, rows: np.ndarray, plans: list[RunPlan]):
        pipelines = [plan.pipeline for plan in plans]
        self.rows = np.asarray(rows, dtype=int)
        self.pipelines = pipelines
        self.declared = {slot: declared_alike(pipelines, slot) for slot in SLOTS}
        self.forms = forms_of(pipelines)
        self.group = group_of([plan.plant for plan in plans], plans[0].timing.steps_per_tick)
        self.outputs = {slot: {} for slot in SLOTS}  # the last tick's, a row per world of the cohort
        self.ticks = 0

    def leave(self, failed: dict) -> None:
        """The worlds at cohort rows `failed` (row -> anything) leave: their forms' state written
        back (`settle`), the others kept."""
        for row in sorted(failed):
            for form in self.forms.values():
                form.settle(row)
        kept = np.array([row for row in range(len(self.rows)) if row not in failed], dtype=int)
        for form in (*self.forms.values(), self.group):
            form.keep(kept)
        self.pipelines = [self.pipelines[row] for row in kept]
        for slot, out in self.outputs.items():  # in place: a tick under way holds this dict
            self.outputs[slot] = {key: values[kept] for key, values in out.items()}
        self.rows = self.rows[kept]


class SteppedBatch:
    """N worlds, one per plan (all of one timing, one rate), stepped together by `step`; `restart`
    puts new plans in some rows. `status`, `error` and `ticks` per row; `plants` the rows' plants."""

    def __init__(self, plans: list[RunPlan], threads: int = 1):
        if not plans:
            raise ValueError("a stepped batch needs at least one world")
        self.timing = plans[0].timing
        if self.timing.multirate:
            raise ValueError("a stepped batch steps one rate: sensors faster than the law run as single runs")
        n = len(plans)
        self.plans = [None] * n
        self.status, self.error = ["ok"] * n, [None] * n
        self.ticks = np.zeros(n, dtype=int)
        self.cohorts: list[Cohort] = []
        self.physics = PhysicsThreads(threads)  # the worlds' physics on this many threads
        self.restart(np.arange(n), plans)

    @property
    def plants(self) -> list:
        return [plan.plant for plan in self.plans]

    def restart(self, rows, plans: list[RunPlan]) -> None:
        """The worlds at `rows` start again at t = 0 from `plans` (one each, of this batch's timing),
        together as one new cohort; the other worlds go on where they are."""
        rows = np.asarray(rows, dtype=int)
        if len(rows) != len(plans) or len(set(rows.tolist())) != len(rows):
            raise ValueError("restart gives one plan to each of distinct rows")
        for plan in plans:
            if plan.timing != self.timing:
                raise ValueError(f"worlds of a batch share one timing: {plan.scenario.name} differs")
        if not len(rows):
            return
        leaving = set(rows.tolist())
        for cohort in self.cohorts:
            cohort.leave({row: None for row, world in enumerate(cohort.rows.tolist()) if world in leaving})
        order = np.argsort(rows)
        rows, plans = rows[order], [plans[i] for i in order]
        for row, plan in zip(rows.tolist(), plans):
            self.plans[row] = plan
            self.status[row], self.error[row] = "ok", None
        self.ticks[rows] = 0
        self.cohorts = [cohort for cohort in self.cohorts if len(cohort.rows)] + [Cohort(rows, plans)]

    def step(self, given: dict | None = None, rows: np.ndarray | None = None) -> None:
        """One control period of every running world (of those `rows`, (N,) bool, marks: the worlds
        that started together are stepped together or not at all). `given`: slot -> {key: (N, ...)},
        that slot's output for every row this period in place of its stage's (checked by the
        caller: finite, of the slot's shapes)."""
        given = given or {}
        with one_blas_thread(), np.errstate(over="raise", invalid="raise", divide="raise"):
            for cohort in self.cohorts:
                marked = rows is None or rows[cohort.rows].all()
                if rows is not None and not marked and rows[cohort.rows].any():
                    raise ValueError(f"worlds {cohort.rows.tolist()} started together: step them together "
                                     f"(restart the others first)")
                if len(cohort.rows) and marked:
                    self._tick(cohort, given)
        self.cohorts = [cohort for cohort in self.cohorts if len(cohort.rows)]

    # --- inside ------------------------------------------------------------------------------
    def _tick(self, cohort: Cohort, given: dict) -> None:
        """The cohort's four slots at its time t (a given slot's output taken as it is), each world's
        command to its plant, the physics to t + Tc, then a look for a bad state."""
        timing = self.timing
        t = cohort.ticks * timing.control_period_s
        group = cohort.group

        def take(name, call):
            if name in given:
                return {key: np.asarray(values)[cohort.rows] for key, values in given[name].items()}
            return self._slot(cohort, t, call)

        failed = tick_slots(t, cohort.forms, group, cohort.declared, cohort.outputs, take,
                            lambda: cohort.pipelines, frozenset(given))
        self._stop(cohort, failed, t)
        if not len(cohort.rows):
            return
        self.physics.run(group.step_calls())
        self._stop(cohort, group.check_state(t, timing.steps_per_tick))
        cohort.ticks += 1
        self.ticks[cohort.rows] = cohort.ticks
        if cohort.ticks == timing.n_ticks:
            cohort.leave({row: None for row in range(len(cohort.rows))})

    def _slot(self, cohort: Cohort, t: float, call):
        """A slot's outputs (or the plants' read-outs) for the cohort's worlds; the worlds it failed stop."""
        try:
            return call()
        except WorldsFailed as exc:
            kept = np.array([row for row in range(len(cohort.rows)) if row not in exc.failures], dtype=int)
            self._stop(cohort, exc.failures, t)
            if isinstance(exc.outputs, dict):
                return {key: values[kept] for key, values in exc.outputs.items()}
            return exc.outputs[kept]

    def _stop(self, cohort: Cohort, failed: dict, t: float | None = None) -> None:
        """The worlds at cohort rows `failed` (row -> one of STOPPING) stop with their status and
        error line; within a tick (t given) a bad physical state found now is reported instead of
        a stage's failure, as a single run's loop does."""
        if not failed:
            return
        if t is not None:
            diverged = cohort.group.check_state(t, 0)
            failed = {row: diverged.get(row, exc) for row, exc in failed.items()}
        for row, exc in failed.items():
            assert isinstance(exc, STOPPING), exc
            world = int(cohort.rows[row])
            self.status[world], self.error[world] = stopped_by(exc, self.plans[world].plant)
        cohort.leave(failed)
