"""Running reductions: figures of a whole run (a maximum, the last value, the largest
distance from the first value) updated chunk by chunk, so a metric needs no history.

A reduction is a frozen dataclass (equal reductions are computed once per run, shared by the
metrics that name them) with `start() -> state`, `update(state, chunk) -> state` and
`result(state)`. Each gives exactly what the same numpy expression over the whole history
gives: a maximum is a maximum of per-chunk maxima, and row-wise arithmetic is the same per row.
A chunk without the reduction's key leaves its state unchanged; NaN propagates as np.max does.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from testbed.recording.recorder import Chunk


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


@dataclass(frozen=True)
class NanMax(_OfSignal):
    """max over samples and components of signal `key`, NaN rows skipped (np.nanmax(v));
    NaN when every row is NaN."""

    def update(self, state, chunk: Chunk):
        if self.key not in chunk.signals or len(chunk.time) == 0:
            return state
        return _nanmax(state, chunk.signals[self.key].reshape(-1))

    def result(self, state) -> float:
        return float(super().result(state))


def _nanmax(state, values):
    """np.nanmax over the rows seen so far (fmax skips NaN; NaN only where every row was NaN)."""
    if len(values) == 0:
        return state
    chunk_max = np.fmax.reduce(values, axis=0)
    return chunk_max if state is None else np.fmax(state, chunk_max)


# --- reductions of per-sample values computed from a chunk ------------------------------------
# `rows(chunk)` gives the values a reduction aggregates, one row per sample of the chunk (None
# when the chunk lacks the signals it reads); it is a frozen dataclass or a module-level
# function, so that equal reductions stay equal.

def _exact_partials(terms: list[float]) -> list[float]:
    """Floats p_1, p_2, ... whose exact sum is the exact sum of `terms`, p_1 = math.fsum(terms)
    (correctly rounded) and each next one fsum of what is left: |p_j+1| <= ulp(p_j) / 2. The
    list ends at an exact remainder of 0 (or at a non-finite p_1: NaN, or inf, as np.sum gives)."""
    partials = []
    while True:
        try:
            total = math.fsum(itertools.chain(terms, (-p for p in partials)))
        except ValueError:  # inf - inf
            return [math.nan]
        except OverflowError:  # an intermediate sum beyond the float range: inf, as np.sum gives
            with np.errstate(over="ignore"):
                return [float(np.sum(terms))]
        if not math.isfinite(total):
            return [total]
        if total == 0.0:
            return partials or [0.0]
        partials.append(total)


def _exact_sums(sums, values: np.ndarray):
    """Column sums of `values` (n, k) added to `sums`, held exactly (`_exact_partials`): the
    result does not depend on how the run was cut into chunks (those follow wall time), and the
    mean of a whole run is its correctly rounded sum over n, within np.mean's own rounding
    (~1e-16 relative)."""
    columns = values.reshape(len(values), -1).T
    if sums is None:
        sums = [[] for _ in columns]
    return [_exact_partials([*partials, *column.tolist()]) for partials, column in zip(sums, columns)]


def _summed(state, values: np.ndarray):
    """(column sums, row count) of a mean so far (None: no rows yet) with `values` added (_exact_sums)."""
    sums, count = state or (None, 0)
    return _exact_sums(sums, values), count + len(values)


def _mean_of(state) -> np.ndarray:
    """The column means a `_summed` state holds (each column's correctly rounded sum over the
    count); NaN without rows."""
    sums, count = state or (None, 0)
    return np.array([partials[0] for partials in sums]) / count if count else np.array([np.nan])


@dataclass(frozen=True)
class Mean:
    """Column means of rows(chunk) over every row of the run (np.mean(v, axis=0)); NaN without rows."""

    rows: Callable

    def start(self):
        return None

    def update(self, state, chunk: Chunk):
        values = self.rows(chunk)
        if values is None or len(values) == 0:
            return state
        return _summed(state, values)

    def result(self, state) -> np.ndarray:
        return _mean_of(state)


@dataclass(frozen=True)
class NanMaxBefore:
    """Column maxima of rows(chunk) over the samples with t < `until`, NaN rows skipped
    (np.nanmax); NaN when no sample is that early."""

    rows: Callable
    until: float

    def start(self):
        return None

    def update(self, state, chunk: Chunk):
        early = chunk.time < self.until
        if not early.any():
            return state
        values = self.rows(chunk)
        return state if values is None else _nanmax(state, values[early])

    def result(self, state):
        return np.nan if state is None else state


@dataclass(frozen=True)
class FirstFrom:
    """rows(chunk) at the first sample with t >= `at`; NaN when the run ends before `at`."""

    rows: Callable
    at: float

    def start(self):
        return None

    def update(self, state, chunk: Chunk):
        if state is not None:
            return state
        after = np.flatnonzero(chunk.time >= self.at)
        values = self.rows(chunk) if after.size else None
        return None if values is None else values[after[0]].copy()

    def result(self, state):
        return np.nan if state is None else state


# Samples a tail window keeps for a run that ends before its planned end (see _Tail).
CUT_SHORT_ROWS = 65536


class _TailState:
    """What a tail window holds: the first and last sample times, the aggregate over the planned
    window, and the latest samples (`recent_t`, `recent`) for a run cut short."""

    def __init__(self):
        self.t0 = self.t_last = self.planned_start = None
        self.planned = None
        self.recent_t, self.recent = np.empty(0), None
        self.dropped_until = -np.inf  # [s] the latest sample dropped to keep CUT_SHORT_ROWS


@dataclass(frozen=True)
class _Tail:
    """An aggregate of rows(chunk) over the samples of the last `fraction` of the run,
    t >= t_e - fraction (t_e - t_0), t_0 and t_e its first and last sample.

    `end_time` is the planned t_e (SimConfig.end_time_s): a run that completes ends there, and
    the aggregate over t >= planned start is kept as the run goes, in constant memory. A run cut
    short (diverged, error) ends at an earlier t_e, whose window starts earlier: for it the
    samples from t_e' - fraction (t_e' - t_0) on are kept as the run goes (t_e' the latest sample
    so far; the final window starts no earlier), at most CUT_SHORT_ROWS of them. Its aggregate
    is exact when the window fits in them; otherwise `result` says so (ValueError)."""

    rows: Callable
    fraction: float
    end_time: float

    def start(self):
        return _TailState()

    def _start_of_window(self, t_end, t0):
        return t_end - self.fraction * (t_end - t0)  # the same expression for the plan and the end

    def update(self, state: _TailState, chunk: Chunk):
        values = self.rows(chunk) if len(chunk.time) else None
        if values is None:
            return state
        t = chunk.time
        if state.t0 is None:
            state.t0 = t[0]
            state.planned_start = self._start_of_window(self.end_time, state.t0)
        state.t_last = t[-1]
        planned = t >= state.planned_start
        if planned.any():
            state.planned = self._aggregate(state.planned, values[planned])
        recent_t = np.concatenate([state.recent_t, t])
        recent = values if state.recent is None else np.concatenate([state.recent, values])
        # rows before the window of a run ending now cannot be in the final window (a margin
        # of 1e-9 of the run for the rounding of that start)
        first = np.searchsorted(recent_t, self._start_of_window(state.t_last, state.t0)
                                - 1e-9 * max(abs(state.t_last), abs(state.t0), 1.0))
        if len(recent_t) - first > CUT_SHORT_ROWS:
            first = len(recent_t) - CUT_SHORT_ROWS
            state.dropped_until = recent_t[first - 1]
        state.recent_t, state.recent = recent_t[first:], recent[first:]
        return state

    def result(self, state: _TailState):
        if state.t0 is None:
            raise ValueError("the signals of the tail window were not recorded")
        if state.t_last == self.end_time:
            return self._finish(state.planned)
        start = self._start_of_window(state.t_last, state.t0)
        if state.dropped_until >= start:
            raise ValueError(f"the run ended at {state.t_last:g} s, before its planned end {self.end_time:g} s, "
                             f"and the last {self.fraction:.0%} of it holds more than the {CUT_SHORT_ROWS} "
                             "samples kept for a run cut short")
        return self._finish(self._aggregate(None, state.recent[state.recent_t >= start]))


@dataclass(frozen=True)
class TailMean(_Tail):
    """Column means of rows(chunk) over the last `fraction` of the run (see _Tail); the sums
    are kept as in Mean."""

    def _aggregate(self, state, values):
        return _summed(state, values)

    def _finish(self, state):
        return _mean_of(state)


@dataclass(frozen=True)
class TailNanMax(_Tail):
    """Column maxima of rows(chunk) over the last `fraction` of the run, NaN rows skipped
    (np.nanmax; see _Tail)."""

    def _aggregate(self, state, values):
        return _nanmax(state, values)

    def _finish(self, state):
        return np.nan if state is None else state


@dataclass(frozen=True)
class WindowPeakRatio(_OfSignal):
    """max_k peak_{k+1} / peak_k, peak_k = max |v| (Euclidean norm of each row of signal `key`)
    over the samples of window k = floor((t - t_0) / `window` + 1e-9), consecutive windows that
    hold samples (< 1: every window's peak below the one before); NaN with fewer than two."""

    window: float

    def start(self):
        return {"t0": None, "k": None, "peak": None, "previous": None, "ratio": None}

    def update(self, state, chunk: Chunk):
        if self.key not in chunk.signals or len(chunk.time) == 0:
            return state
        if state["t0"] is None:
            state["t0"] = chunk.time[0]
        index = np.floor((chunk.time - state["t0"]) / self.window + 1e-9).astype(int)
        norms = np.linalg.norm(chunk.signals[self.key].reshape(len(index), -1), axis=1)
        for k in np.unique(index):
            peak = np.max(norms[index == k])
            if k == state["k"]:
                state["peak"] = np.maximum(state["peak"], peak)  # NaN wins, as np.max
                continue
            self._close(state)
            state["k"], state["peak"] = k, peak
        return state

    @staticmethod
    def _close(state) -> None:
        """The window `k` is complete: its ratio to the window before."""
        if state["previous"] is not None:
            ratio = state["peak"] / state["previous"]
            state["ratio"] = ratio if state["ratio"] is None else np.maximum(state["ratio"], ratio)
        state["previous"] = state["peak"]

    def result(self, state) -> float:
        final = dict(state)
        if final["k"] is not None:
            self._close(final)
        return np.nan if final["ratio"] is None else float(final["ratio"])


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
