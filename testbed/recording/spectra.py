"""Spectra computed from a run's recorded signals after it, written into its trace as bar charts.

A spectrum registers with `@spectrum(name, applies, uses, unit)`, like a metric
(testbed.metrics.metric): `fn(run) -> (frequencies [Hz], density)` from the run's kept
signals (`uses`: the signal keys it reads whole). The trace holds it at `spectrum/<name>`
(abscissa in Hz, value in `unit`) in a tab of its own; one that cannot be computed (a run cut
short before the window it needs) is left out.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from testbed.interrupts import from_a_signal
from testbed.registry import Registry

ENTITY = "spectrum"


@dataclass(frozen=True)
class Spectrum:
    name: str
    doc: str
    applies: Callable
    compute: Callable
    uses: tuple
    unit: str


SPECTRA = Registry("spectrum")


def spectrum(name: str, applies: Callable, uses: tuple, unit: str):
    """Register `fn(run) -> (frequencies [Hz], values [unit])` as spectrum `name` (docstring's
    first line: what it is)."""

    def register(fn):
        SPECTRA.add(name, Spectrum(name, (fn.__doc__ or "").strip().splitlines()[0], applies, fn, tuple(uses), unit),
                    fn.__module__)
        return fn

    return register


def available(scenario) -> list[Spectrum]:
    return [s for _, s in SPECTRA.items() if s.applies(scenario)]


def compute_all(run) -> dict[str, tuple[np.ndarray, np.ndarray, str]]:
    """name -> (frequencies [Hz], values, view title) of every spectrum of the run that has finite values."""
    out = {}
    for s in available(run.scenario):
        try:
            with np.errstate(all="ignore"):
                freq, values = s.compute(run)
        except BaseException as exc:  # a run cut short: no window to take the spectrum of
            if from_a_signal(exc):
                raise
            continue
        freq, values = np.asarray(freq, float), np.asarray(values, float)
        if len(freq) and np.all(np.isfinite(values)):
            out[s.name] = (freq, values, f"{s.doc} [{s.unit}] against frequency [Hz]")
    return out
