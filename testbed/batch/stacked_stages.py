"""The batched form of a stage whose method keeps no state from tick to tick: the stage class's
own method, run once on an object whose per-world attributes are the worlds' values stacked.

A stage class that is written on arrays with leading axes (its numbers broadcast: a scalar
parameter as (N, 1), a vector as (N, 3), a matrix as (N, 3, 3)) gives, from its `batched`
classmethod, `StatelessForm(stages, slot, names)` with the names of the attributes its method
reads that differ from world to world. Each piece of math then exists once: the single run calls the same method on
its own unstacked attributes. The rows are computed under the single run's floating-point rules
(overflow, invalid and division raise); when the method raises on them (one row's overflow, a
check of its inputs that one row fails), every world's own stage is run instead that tick, and
a row that comes out non-finite is replayed on its world's own stage: a failure (or, were the
batched arithmetic alone to blame, an output) is the single run's, word for word. Replaying is
sound because the stage keeps no state from tick to tick.
"""

from __future__ import annotations

import numpy as np

from testbed.batch.stage_forms import WorldsFailed, rows_of
from testbed.errors import described
from testbed.interrupts import from_a_signal
from testbed.run_core.stage_contract import Declared, MethodFailed, StageFailed

# each slot's method (testbed.run_core.stage_contract)
METHODS = {"sensor": "measure", "estimator": "estimate", "law": "torque", "allocator": "allocate"}


def stacked_attributes(stages: list, names: tuple) -> object:
    """An object of the stages' class (its __init__ not run) whose attributes `names` are the
    worlds' values stacked on a leading axis, a scalar as a column (N, 1) so that it broadcasts
    against the worlds' (N, k) rows."""
    rows = object.__new__(type(stages[0]))
    for name in names:
        values = np.array([getattr(stage, name) for stage in stages], dtype=float)
        setattr(rows, name, values[:, None] if values.ndim == 1 else values)
    return rows


def failure_of(t: float, slot: str, stage, exc: BaseException) -> StageFailed:
    """The StageFailed a single run ends with when `stage` in `slot` raised `exc` at t
    (testbed.run_core.tick.Pipeline._raise_failure)."""
    if isinstance(exc, StageFailed):
        return exc
    name = Declared.of(stage).type_name or type(stage).__name__
    if isinstance(exc, MethodFailed):
        return StageFailed(t, slot, name, exc.reason, method=True)
    return StageFailed(t, slot, name, described(exc))


def nonfinite_rows(outputs: dict) -> np.ndarray:
    """The rows (indices) where any of `outputs` (key -> (N, ...)) holds a non-finite number."""
    bad = None
    for values in outputs.values():
        row_bad = ~np.isfinite(values.reshape(len(values), -1)).all(axis=1)
        bad = row_bad if bad is None else bad | row_bad
    return np.flatnonzero(bad) if bad is not None else np.zeros(0, int)


class StatelessForm:
    """`slot`'s method of the worlds' `stages` on (N, ...) rows: their class's own method on the
    stacked attributes `names` (`stacked_attributes`) and on `parts` (attribute name -> an object
    of the worlds' parts as one, with `keep(rows)`). When the method raises on the rows (a check
    of its inputs that one row fails), every world's own stage is run instead, that tick."""

    def __init__(self, stages: list, slot: str, names: tuple, parts: dict | None = None):
        self.stages, self.slot, self.names = list(stages), slot, tuple(names)
        self.parts = dict(parts or {})
        self.rows = stacked_attributes(self.stages, self.names)
        for name, part in self.parts.items():
            setattr(self.rows, name, part)
        self.method = getattr(type(self.stages[0]), METHODS[slot])
        setattr(self, METHODS[slot], self._call)

    def keep(self, rows: np.ndarray) -> None:
        self.stages = [self.stages[i] for i in rows]
        for name in self.names:
            setattr(self.rows, name, getattr(self.rows, name)[rows])
        for part in self.parts.values():
            part.keep(rows)

    def settle(self, row: int) -> None:
        """Nothing to write back: the stage keeps no state."""

    def _call(self, t: float, *given):
        """given: the method's arguments after t, dicts of (N, ...) rows (a sensor's: the plants)."""
        count = len(self.stages)
        try:  # under the single run's rules: an overflow inside, even one that ends finite, fails a world
            with np.errstate(over="raise", invalid="raise", divide="raise"):
                outputs = self.method(self.rows, t, *given)
            bad = nonfinite_rows(outputs)
        except Exception:  # noqa: BLE001  (each world's own stage says whose row it was)
            outputs, bad = None, np.arange(count)
        if not len(bad):
            return outputs
        failures, alone_outputs = {}, {}
        for row in bad.tolist():
            mine = [rows_of(arg, count)[row] if isinstance(arg, dict) else arg[row] for arg in given]
            try:
                with np.errstate(over="raise", invalid="raise", divide="raise"):
                    alone = getattr(self.stages[row], METHODS[self.slot])(t, *mine)
            except BaseException as exc:  # noqa: BLE001  (what the world's own stage raised ends that world)
                if from_a_signal(exc):
                    raise
                failures[row] = failure_of(t, self.slot, self.stages[row], exc)
                continue
            alone_outputs[row] = alone  # the batched arithmetic alone overflowed: take the world's own
        if outputs is None:  # every row replayed: the rows' own outputs, a failed row's not a number
            alive = next(iter(alone_outputs.values()), {})
            outputs = {key: np.full((count,) + np.shape(value), np.nan) for key, value in alive.items()}
        else:  # (the outputs may be the inputs themselves: a pass-through's)
            outputs = {key: np.array(value, dtype=float) for key, value in outputs.items()}
        for row, alone in alone_outputs.items():
            for key, value in alone.items():
                outputs[key][row] = value
        if failures:
            raise WorldsFailed(failures, outputs)
        return outputs
