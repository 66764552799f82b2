"""A pipeline slot's stage on many worlds at once: its batched form, or the worlds' own stages one by one.

A stage class may declare `batched`, a classmethod taking the stage objects of the N worlds (all
of its class) and giving a `BatchedForm`: the slot's method on (N, ...) arrays, a row per world
(or None where these worlds' configuration has no batched form). A slot without one, every
plug-in's among them, runs through `PerWorld`, which calls each world's
own stage as a single run would. Either way a world's failure is its own: it leaves the batch and
its batch-mates go on (`WorldsFailed`).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from testbed.run_core.stage_contract import SLOTS, Declared, StageFailed
from testbed.run_core.tick import stage_failure


class BatchedForm(Protocol):
    """A stage's form on N worlds: the slot's method (`measure(t, plants)`, `estimate(t,
    measurement, command)`, `torque(t, estimate)` or `allocate(t, demand, estimate, actuators)`)
    with every dict of arrays carrying a leading axis of one row per world in the batch (plants: a
    list), and every row computed as that world's own stage would (to round-off: a form says how
    close in its tests). A row whose numbers turn non-finite or leave the method's validity is
    reported by raising `WorldsFailed` with the outputs of the others."""

    def keep(self, rows: np.ndarray) -> None:
        """Only the worlds at `rows` (indices of the current rows, increasing) go on."""

    def settle(self, row: int) -> None:
        """Write row's state that a result reads (statistics, counters) back into its world's stage."""


class WorldsFailed(Exception):
    """Raised by a slot's form when some worlds' rows failed: `failures` row -> the StageFailed
    that ends that world's run, `outputs` the slot's outputs for every row (a failed row's as it is)."""

    def __init__(self, failures: dict[int, StageFailed], outputs: dict):
        self.failures, self.outputs = failures, outputs
        super().__init__(f"{len(failures)} worlds failed")


def replayed(t: float, slot: str, stage, call) -> tuple:
    """(call(), None), `call` a world's own stage redoing its step at t [s] under the run's
    floating-point errors (a batched form's way to fail a row exactly as its single run does),
    or (None, the StageFailed a single run's tick makes of what it raised)."""
    try:
        return call(), None
    except Exception as exc:   # (a signal's stop, a BaseException, goes through)
        return None, stage_failure(t, slot, stage, exc)


def rows_of(signals: dict, count: int) -> list[dict]:
    """The per-world dicts of `signals` (key -> (count, ...)): row i's views."""
    return [{key: value[i] for key, value in signals.items()} for i in range(count)]


def nan_like(alive: dict | None) -> dict:
    """A failed world's row: NaN in the shape of each of a live world's outputs `alive` ({} if none)."""
    return {key: np.full(np.shape(value), np.nan) for key, value in (alive or {}).items()}


def stacked(outputs: list[dict]) -> dict:
    """The per-world dicts `outputs` as one dict of (N, ...) arrays (each world's keys the same)."""
    if not outputs or not outputs[0]:
        return {}
    return {key: np.array([out[key] for out in outputs], dtype=float) for key in outputs[0]}


class PerWorld:
    """A slot run per world: each world's own stage, checked and failing as in a single run
    (through the world's `Pipeline`, testbed.run_core.tick)."""

    def __init__(self, slot: str, pipelines: list):
        self.slot, self.pipelines = slot, list(pipelines)

    def keep(self, rows: np.ndarray) -> None:
        self.pipelines = [self.pipelines[i] for i in rows]

    def settle(self, row: int) -> None:
        """Nothing to write back: each world's stage is its own."""

    def _each(self, t: float, call) -> dict:
        outputs, failures = [], {}
        for row, pipeline in enumerate(self.pipelines):
            try:
                outputs.append(call(row, pipeline))
            except StageFailed as exc:
                failures[row] = exc
                outputs.append(None)
        if failures:
            filler = nan_like(next((out for out in outputs if out is not None), None))
            raise WorldsFailed(failures, stacked([filler if out is None else out for out in outputs]))
        return stacked(outputs)

    def measure(self, t: float, plants: list) -> dict:
        return self._each(t, lambda row, pipeline: pipeline.run_sensor(t, plants[row]))

    def estimate(self, t: float, measurement: dict, command: dict) -> dict:
        measured, commanded = rows_of(measurement, len(self.pipelines)), rows_of(command, len(self.pipelines))
        return self._each(t, lambda row, pipeline: pipeline.run_estimator(t, measured[row], commanded[row]))

    def torque(self, t: float, estimate: dict) -> dict:
        estimates = rows_of(estimate, len(self.pipelines))
        return self._each(t, lambda row, pipeline: pipeline.run_law(t, estimates[row]))

    def allocate(self, t: float, demand: dict, estimate: dict, actuators: dict) -> dict:
        n = len(self.pipelines)
        demands, estimates, read = rows_of(demand, n), rows_of(estimate, n), rows_of(actuators, n)
        return self._each(t, lambda row, pipeline: pipeline.run_allocator(t, demands[row], estimates[row], read[row]))


def form_of(slot: str, pipelines: list):
    """The slot's form on the worlds of `pipelines`: the stages' batched form when every world's
    stage is of one built-in class that declares one, none has an output check and the class
    gives one for these worlds (its `batched` may answer None: e.g. options it does not batch),
    else `PerWorld`."""
    stages = [pipeline.stages()[slot] for pipeline in pipelines]
    kinds = {type(stage) for stage in stages}
    declared = pipelines[0].declared[slot]
    form = None
    if len(kinds) == 1 and declared.batched is not None and not any(slot in p.checks for p in pipelines):
        form = declared.batched(stages)
    return PerWorld(slot, pipelines) if form is None else form


def forms_of(pipelines: list) -> dict:
    """slot -> its form on the worlds of `pipelines` (`form_of`)."""
    return {slot: form_of(slot, pipelines) for slot in SLOTS}


def declared_alike(pipelines: list, slot: str) -> Declared:
    """What the worlds' stages in `slot` declare, which a batch reads once for all of them;
    refused (ValueError) when the worlds' stages declare differently what the tick reads."""
    first = pipelines[0].declared[slot]
    for pipeline in pipelines[1:]:
        other = pipeline.declared[slot]
        if (other.needs_actuators, other.inputs, other.output) != (first.needs_actuators, first.inputs, first.output):
            raise ValueError(f"the worlds' {slot} stages read or command differently: batch them apart")
    return first


def tick_slots(t: float, forms: dict, group, declared: dict, outputs: dict, take, pipelines,
               given=frozenset()) -> dict:
    """One control tick of the four slots at t [s] on the live worlds' rows, into `outputs` (slot
    -> {key: (N, ...)}, the last tick's allocator output read by the estimator), then each world's
    command to its plant (`group.apply`). `take(slot, call)` gives a slot's outputs, or the plants'
    read-outs, from `call()` with the worlds it failed gone (the caller's rule for a world that
    leaves); `given`: the slots whose outputs `take` supplies itself (their stages and the reads
    only they need are skipped); `pipelines()`: the live worlds' pipelines once the slots have run.
    Returns row -> the StageFailed of each world whose plant refused its command (the
    allocator's failure, as in a single run's tick)."""
    outputs["sensor"] = take("sensor", lambda: forms["sensor"].measure(t, group.plants))
    outputs["estimator"] = take("estimator", lambda: forms["estimator"].estimate(
        t, outputs["sensor"], outputs["allocator"]))
    momentum = {}
    if "law" not in given and "internal_momentum" in declared["law"].inputs:
        momentum = {"internal_momentum": take(None, group.internal_momentum_body)}
    estimate = outputs["estimator"] | momentum  # (after the read: a world it failed has left the estimates too)
    outputs["law"] = take("law", lambda: forms["law"].torque(t, estimate))
    actuators = (take(None, group.actuator_state)
                 if "allocator" not in given and declared["allocator"].needs_actuators else {})
    outputs["allocator"] = take("allocator", lambda: forms["allocator"].allocate(
        t, outputs["law"], outputs["estimator"], actuators))
    failed = {}
    for row, exc in group.apply(outputs["allocator"]).items():
        try:
            pipelines()[row]._raise_failure(t, "allocator", exc)
        except StageFailed as failure:
            failed[row] = failure
    return failed
