"""A run's trace chunks on their way out: derived signals, the reference, the reductions, the file."""

from __future__ import annotations

import warnings

import numpy as np

from testbed.recording.recorder import Chunk
from testbed.references.registry import DeclaredReference


class ChunkStream:
    """What happens to each chunk of trace samples as the run goes: the plant's derived signals
    are added, the reference advances (`update` of a streaming reference), the metrics'
    reductions are updated and the chunk is written; the reference's rows go back to the
    recorder to keep. A reference that needs the whole run is evaluated by `finish` on the kept
    history; a reference that fails is left out, its reason kept (`reference_error`) for the
    metrics that need it."""

    def __init__(self, plant, reference, reductions, writer):
        self.plant, self.reference, self.reductions, self.writer = plant, reference, reductions, writer
        self.declared = DeclaredReference.of(reference)
        self.reference_error = None

    def __call__(self, chunk) -> list[Chunk]:
        with np.errstate(all="ignore"):  # NaN rows of a run cut short are recorded as they are
            chunk.signals.update(self.plant.derived_signals(chunk))
        self._emit(chunk)
        if self.reference is not None and self.declared.streaming and self.reference_error is None:
            return self._reference(lambda: self.declared.update(chunk))
        return []

    def finish(self, recorder) -> None:
        """The reference's last rows (a streaming one's), or all of them (one that needs the whole
        run, from the recorder's kept history), into `recorder`."""
        if self.reference is None or self.reference_error is not None:
            return
        if self.declared.streaming:
            rows = self._reference(self.declared.finish)
        elif recorder.count > 1:
            rows = self._reference(lambda: reference_chunk(recorder.time, self.reference(recorder.time, recorder),
                                                            recorder["truth/omega"]))
        else:
            rows = []
        for chunk in rows:
            recorder.keep_chunk(chunk)

    def _reference(self, evaluate) -> list[Chunk]:
        """The chunk `evaluate()` gives, written ([] if none, or if the reference failed)."""
        try:
            with np.errstate(all="ignore"):
                chunk = evaluate()
        except (ValueError, ArithmeticError) as exc:  # e.g. too short a trace to interpolate
            self.reference_error = f"the reference could not be evaluated: {exc}"
            return []
        if chunk is None:
            return []
        self._emit(chunk)
        return [chunk]

    def _emit(self, chunk) -> None:
        # a metric's running reduction under- or overflows to a value that is not finite, which fails
        # its checks with the reason (metrics.compute_all): not a numpy warning, nor the run's divergence
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # numpy's nan-reductions of an all-NaN window
            self.reductions.update(chunk)
        if self.writer is not None:
            self.writer.write(chunk)


def reference_chunk(times, omega_ref, omega_truth, first_row: int = 0) -> Chunk:
    """The reference's rows: `reference/omega` and the truth's error from it."""
    return Chunk(first_row, times, {"reference/omega": omega_ref, "reference/omega_error": omega_truth - omega_ref})
