"""A reference model integrated window by window as the trace chunks arrive, so that its input
histories need not be kept for the whole run.

The run's samples are cut into windows of `window` samples; window j covers samples
[s_j, s_j + window] and starts from the state window j - 1 ended in (the first, from the
reference's initial state). Its inputs are the recorded histories over the window plus
`margin` samples either side, so that interpolating splines fitted to them (a not-a-knot
cubic spline's end effect decays by a factor 2 - sqrt(3) = 0.27 per sample) see the same
history inside the window as a spline over the whole run, to rounding. A run of at most
`window + margin` samples is one window: exactly the whole-run evaluation.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from testbed.recording.recorder import Chunk

WINDOW = 8192
MARGIN = 64


class WindowedReference:
    """`segment(times, inputs, lo, hi, state) -> (omega (hi - lo + 1, 3) at times[lo..hi], state at
    times[hi])` evaluates one window: `times` and `inputs` {key: rows} the buffered samples
    around it. `update(chunk)` and `finish()` return the reference's rows (a Chunk of
    `reference/omega` and `reference/omega_error`) for the windows completed, or None."""

    def __init__(self, segment: Callable, signals: tuple[str, ...], state, window: int = WINDOW,
                 margin: int = MARGIN):
        self.segment, self.signals, self.state = segment, tuple(signals), state
        self.window, self.margin = window, margin
        self.start = 0        # run index of the next window's first sample
        self.base = 0         # run index of the first buffered sample
        self._times: list[np.ndarray] = []
        self._inputs: dict[str, list[np.ndarray]] = {key: [] for key in (*self.signals, "truth/omega")}

    def update(self, chunk: Chunk) -> Chunk | None:
        self._times.append(chunk.time)
        for key, parts in self._inputs.items():
            parts.append(chunk[key])
        end = chunk.first_row + len(chunk.time)  # samples buffered so far (exclusive end)
        done = []
        # a window is evaluated once `margin` samples follow it and `margin` more are left for the last
        while end > self.start + self.window + 2 * self.margin:
            done.append(self._evaluate(self.start + self.window, last=False))
        return _joined(done)

    def finish(self) -> Chunk | None:
        end = self.base + sum(len(t) for t in self._times)
        return self._evaluate(end - 1, last=True) if end - 1 > self.start else None

    def _evaluate(self, stop: int, last: bool) -> Chunk:
        """Integrate samples [start, stop]; rows [start, stop) are emitted (all, for the last window)."""
        times = np.concatenate(self._times)
        inputs = {key: np.concatenate(parts) for key, parts in self._inputs.items()}
        first = max(self.base, self.start - self.margin)
        upto = min(self.base + len(times), stop + self.margin + 1)
        window = slice(first - self.base, upto - self.base)
        lo, hi = self.start - first, stop - first
        omega, self.state = self.segment(times[window], {k: v[window] for k, v in inputs.items()}, lo, hi, self.state)
        rows = slice(lo, hi + 1 if last else hi)
        t = times[window][rows]
        omega = omega[: len(t)]
        chunk = Chunk(self.start, t, {"reference/omega": omega,
                                      "reference/omega_error": inputs["truth/omega"][window][rows] - omega})
        # keep only what the next window's margin needs
        self.start = stop
        keep_from = max(self.base, self.start - self.margin) - self.base
        self._times = [times[keep_from:]]
        self._inputs = {key: [values[keep_from:]] for key, values in inputs.items()}
        self.base += keep_from
        return chunk


def _joined(chunks: list[Chunk]) -> Chunk | None:
    if not chunks:
        return None
    return Chunk(chunks[0].first_row, np.concatenate([c.time for c in chunks]),
                 {key: np.concatenate([c.signals[key] for c in chunks]) for key in chunks[0].signals})
