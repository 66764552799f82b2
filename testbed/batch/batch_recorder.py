"""The trace samples of many worlds, a row per sample and a column per world, handed to each
world's own recorder a chunk at a time (testbed.recording.recorder.Recorder.take_chunk)."""

from __future__ import annotations

import numpy as np

from testbed.recording.recorder import CHUNK_ROWS, Chunk


class BatchRecorder:
    """Buffers of (chunk_rows, N, ...) for the N worlds of a batch; `sample` writes the rows of
    the worlds `live` (their indices among the N), `flush` hands each live world its column as
    the chunk its own recorder would have flushed (same keys in the same order, NaN where a
    signal was not recorded). Memory: chunk_rows x N x the signals' width x 8 bytes."""

    def __init__(self, recorders: list, chunk_rows: int = CHUNK_ROWS):
        self.recorders, self.chunk_rows = recorders, chunk_rows
        self._time = np.empty(chunk_rows)
        self._buffers: dict[str, np.ndarray] = {}
        self._rows = 0
        self._live = np.zeros(0, dtype=int)  # the worlds of the buffered rows: the batch flushes before one leaves

    def sample(self, t: float, groups: dict[str, dict[str, np.ndarray]], live: np.ndarray) -> None:
        """One trace sample at time t [s]: groups {group: {name: (len(live), ...)}} of the worlds
        `live` (the same worlds since the last flush)."""
        i = self._rows
        self._time[i] = t
        self._live = live
        buffers = self._buffers
        for group, signals in groups.items():
            for name, values in signals.items():
                key = f"{group}/{name}"
                buf = buffers.get(key)
                if buf is None:
                    # rows a signal did not produce (before its stage first ran) stay NaN, as in a Recorder
                    buf = buffers[key] = np.full((self.chunk_rows, len(self.recorders)) + np.shape(values)[1:], np.nan)
                buf[i, live] = values
        self._rows = i + 1
        if self._rows == self.chunk_rows:
            self.flush()

    def flush(self) -> None:
        """Hand each world of the buffered rows its column, as one chunk."""
        n = self._rows
        if n == 0:
            return
        time = self._time[:n]
        for world in self._live.tolist():
            recorder = self.recorders[world]
            recorder.take_chunk(Chunk(recorder.count, time.copy(),
                                      {key: buf[:n, world].copy() for key, buf in self._buffers.items()}))
        for buf in self._buffers.values():
            buf[:n] = np.nan
        self._rows = 0
