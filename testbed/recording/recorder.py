"""Signal buffers filled at the trace period and handed on in chunks as the run goes, the
history of the signals a run keeps, and the `Trace` view of a run's signals as numpy arrays.

Logging sample by sample costs 20-60 us a call in Rerun 0.41; preallocated numpy buffers cost
well under a microsecond per signal and are flushed with `send_columns`. The buffers hold one
chunk (`chunk_rows` samples, or less when `flush_after_s` of wall time has passed since the
last chunk), so memory does not grow with the run; only the signals named in `keep` (all of
them by default) are kept for the whole run, e.g. for the metrics that need a history.
"""

from __future__ import annotations

import time as _clock
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

CHUNK_ROWS = 4096
FLUSH_AFTER_S = 1.0  # [s] of wall time: the longest a written run holds samples back


@dataclass
class Chunk:
    """Consecutive trace samples: `time` (n,) [s], `signals` {key: (n, ...)} and the index of
    its first sample in the run (`first_row`). A listener may add signals computed from the
    others (same rows)."""

    first_row: int
    time: np.ndarray
    signals: dict[str, np.ndarray]

    def __getitem__(self, key: str) -> np.ndarray:
        return self.signals[key]

    def __contains__(self, key: str) -> bool:
        return key in self.signals


class _History:
    """One kept signal: rows placed by their index in the run, NaN where it was not recorded;
    the buffer doubles when full, so appending costs O(1) amortised."""

    def __init__(self, shape: tuple, capacity: int):
        self.rows = np.full((max(capacity, 1),) + shape, np.nan)

    def put(self, first_row: int, values: np.ndarray) -> None:
        end = first_row + len(values)
        self.reserve(end)
        self.rows[first_row:end] = values

    def reserve(self, end: int) -> None:
        if end > len(self.rows):
            grown = np.full((max(end, 2 * len(self.rows)),) + self.rows.shape[1:], np.nan)
            grown[: len(self.rows)] = self.rows
            self.rows = grown

    def first(self, n: int) -> np.ndarray:
        self.reserve(n)
        return self.rows[:n]


class Recorder:
    """Signals keyed `group/name`, one row per sample, all sharing one time column.

    `on_chunk(chunk)` is called with every full chunk (and the last, partial one on `flush()`);
    the chunks it returns, computed from that one (a reference's rows), are kept with it;
    `keep`: the keys whose whole history `recorder[key]` returns (None: every key)."""

    def __init__(self, chunk_rows: int = CHUNK_ROWS, keep: set[str] | None = None,
                 on_chunk: Callable[[Chunk], list[Chunk]] | None = None, flush_after_s: float | None = None):
        self.chunk_rows = chunk_rows
        self.keep = keep
        self.on_chunk = on_chunk
        self.flush_after_s = flush_after_s
        self.count = 0  # samples recorded so far
        self.last_time = 0.0  # [s] of the last flushed sample
        self._first = 0  # run index of the first row in the buffers
        self._time = np.empty(chunk_rows)
        self._buffers: dict[str, np.ndarray] = {}
        self._by_group: dict[str, dict[str, np.ndarray]] = {}  # the same buffers, for sample()
        self._kept: dict[str, _History] = {}
        self._kept_time = _History((), chunk_rows)
        self._known: dict[str, None] = {}  # every key seen, in order
        self._last_flush = _clock.perf_counter()

    def sample(self, t: float, groups: dict[str, dict[str, np.ndarray]]) -> None:
        i = self.count - self._first
        self._time[i] = t
        by_group = self._by_group
        for group, signals in groups.items():
            buffers = by_group.get(group)
            if buffers is None:  # (not setdefault: that builds a new dict at every sample)
                buffers = by_group[group] = {}
            for name, value in signals.items():
                buf = buffers.get(name)
                if buf is None:
                    # Rows a signal did not produce (e.g. before its stage first ran) stay NaN.
                    buf = np.full((self.chunk_rows,) + np.shape(value), np.nan)
                    buffers[name] = self._buffers[f"{group}/{name}"] = buf
                buf[i] = value
        self.count += 1
        if i + 1 == self.chunk_rows or (self.flush_after_s is not None
                                        and _clock.perf_counter() - self._last_flush > self.flush_after_s):
            self.flush()

    def flush(self) -> None:
        """Hand the buffered rows on as one chunk (to `on_chunk`, then to the kept history)."""
        n = self.count - self._first
        self._last_flush = _clock.perf_counter()
        if n == 0:
            return
        chunk = Chunk(self._first, self._time[:n].copy(), {key: buf[:n].copy() for key, buf in self._buffers.items()})
        for buf in self._buffers.values():
            buf[:n] = np.nan  # rows the next chunk's samples leave out stay NaN
        self._hand_on(chunk)

    def take_chunk(self, chunk: Chunk) -> None:
        """Take `chunk`, the next rows of this run sampled elsewhere (testbed.batch's recorder of
        many worlds), as if they had been sampled here and flushed: handed on, then kept."""
        self.flush()
        self.count += len(chunk.time)
        self._hand_on(chunk)

    def _hand_on(self, chunk: Chunk) -> None:
        """The chunk's rows, the last flushed, to `on_chunk` and the kept history."""
        self.last_time = float(chunk.time[-1])
        self._first = self.count
        if self.keep is None or self.keep:
            self._kept_time.put(chunk.first_row, chunk.time)
        derived = self.on_chunk(chunk) if self.on_chunk is not None else ()
        self.keep_chunk(chunk)
        for extra in derived:
            self.keep_chunk(extra)

    def keep_chunk(self, chunk: Chunk) -> None:
        """Add a chunk's rows (of the run's samples, or computed from them) to the kept history."""
        for key, values in chunk.signals.items():
            self._known.setdefault(key)
            if self.keep is None or key in self.keep:
                history = self._kept.get(key)
                if history is None:
                    history = self._kept[key] = _History(values.shape[1:], chunk.first_row + len(values))
                history.put(chunk.first_row, values)

    @property
    def time(self) -> np.ndarray:
        """Times [s] of the kept samples (every flushed sample while any signal is kept)."""
        return self._kept_time.first(self._first)

    def keys(self) -> list[str]:
        """Every key recorded or added, flushed or not, in order of first appearance."""
        return list(self._known | dict.fromkeys(self._buffers))

    def __contains__(self, key: str) -> bool:
        return key in self._kept

    def __getitem__(self, key: str) -> np.ndarray:
        """The whole kept history of `key` (a row per flushed sample, NaN where not recorded)."""
        return self._kept[key].first(self._first)


class Trace(Mapping):
    """A run's signals as numpy arrays: `trace["truth/omega"] -> (t, values)`, t (N,) [s] and
    values (N, width), only the samples where the signal was recorded (a stage that had not run
    yet, or the final row that holds only the truth, leave a signal's row out)."""

    def __init__(self, signals: dict[str, tuple[np.ndarray, np.ndarray]] | None = None,
                 recorder: Recorder | None = None):
        self._signals = dict(signals or {})
        self._recorder = recorder  # signals cut from it when first asked for

    @classmethod
    def from_recorder(cls, recorder: Recorder) -> "Trace":
        return cls(recorder=recorder)

    def _keys(self) -> list[str]:
        return [k for k in self._recorder.keys() if k in self._recorder]

    def __getitem__(self, key: str) -> tuple[np.ndarray, np.ndarray]:
        if key not in self._signals and self._recorder is not None and key in self._recorder:
            time = self._recorder.time
            values = self._recorder[key].reshape(len(time), -1)
            keep = ~np.all(np.isnan(values), axis=1)
            self._signals[key] = (time[keep], values[keep])
        return self._signals[key]

    def __iter__(self):
        return iter(self._keys() if self._recorder is not None else self._signals)

    def __len__(self) -> int:
        return len(self._keys()) if self._recorder is not None else len(self._signals)
