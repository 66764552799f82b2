"""Running reductions: figures of a whole run (a maximum, the last value, the largest
distance from the first value) updated chunk by chunk, so a metric needs no history.

A reduction is a frozen dataclass (equal reductions are computed once per run, shared by the
metrics that name them) with `start() -> state`, `update(state, chunk) -> state` and
`result(state)`. Each gives exactly what the same numpy expression over the whole history
gives: a maximum is a maximum of per-chunk maxima, and row-wise arithmetic is the same per row.
A chunk without the reduction's key leaves its state unchanged; NaN propagates as np.max does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.recorder import Chunk


def _max(state, values):
    """np.max over the rows seen so far: the larger of the running and the chunk maximum (NaN wins)."""
    if len(values) == 0:
        return state
    return np.max(values, axis=0) if state is None else np.maximum(state, np.max(values, axis=0))


@dataclass(frozen=True)
class _OfSignal:
    """A reduction of signal `key`: its state is None until a chunk holding `key` arrives."""

    key: str

    def start(self):
        return None

    def result(self, state):
        if state is None:
            raise ValueError(f"{self.key} was not recorded")
        return state


@dataclass(frozen=True)
class MaxNorm(_OfSignal):
    """max over samples of |v| (Euclidean norm of each row) of signal `key`."""

    def update(self, state, chunk: Chunk):
        if self.key not in chunk.signals:
            return state
        return _max(state, np.linalg.norm(chunk.signals[self.key], axis=1))

    def result(self, state) -> float:
        return float(super().result(state))


@dataclass(frozen=True)
class MaxAbs(_OfSignal):
    """max over samples and components of |v| of signal `key` (np.max(np.abs(v)))."""

    def update(self, state, chunk: Chunk):
        if self.key not in chunk.signals:
            return state
        values = np.abs(chunk.signals[self.key])
        return _max(state, values.reshape(len(values), -1).max(axis=1))

    def result(self, state) -> float:
        return float(super().result(state))


@dataclass(frozen=True)
class MaxDistanceFromFirst(_OfSignal):
    """max over samples of |v(t) - v(t_0)|, v(t_0) the signal's first recorded row."""

    def start(self):
        return (None, None)

    def update(self, state, chunk: Chunk):
        first, peak = state
        if self.key not in chunk.signals or len(chunk.time) == 0:
            return state
        values = chunk.signals[self.key]
        if first is None:
            first = values[0].copy()
        return first, _max(peak, np.linalg.norm(values - first, axis=1))

    def result(self, state) -> float:
        return float(super().result(state[1]))


@dataclass(frozen=True)
class First(_OfSignal):
    """The first recorded row of signal `key` (the run's initial sample)."""

    def update(self, state, chunk: Chunk):
        if state is not None or self.key not in chunk.signals or len(chunk.time) == 0:
            return state
        return chunk.signals[self.key][0].copy()


@dataclass(frozen=True)
class Last(_OfSignal):
    """The last recorded row of signal `key` (the run's final sample)."""

    def update(self, state, chunk: Chunk):
        if self.key not in chunk.signals or len(chunk.time) == 0:
            return state
        return chunk.signals[self.key][-1].copy()


class Reductions:
    """The states of a run's reductions, fed every chunk (`update`) and read by metrics (`value`)."""

    def __init__(self, reductions=()):
        self._states = {r: r.start() for r in dict.fromkeys(reductions)}

    def update(self, chunk: Chunk) -> None:
        for reduction, state in self._states.items():
            self._states[reduction] = reduction.update(state, chunk)

    def value(self, reduction):
        if reduction not in self._states:
            raise KeyError(f"{reduction} was not declared by the metric that reads it")
        return reduction.result(self._states[reduction])
