"""Metrics of a run in orbit: the pointing error in the target frame and the magnetorquers'
use of their dipole limits (running reductions: a 10-orbit run keeps no history)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.metrics import metric
from testbed.recording.reductions import _OfSignal



@dataclass(frozen=True)
class SettledNanMax(_OfSignal):
    """max over the samples after `after_s` [s] of signal `key` (NaN rows skipped)."""

    after_s: float = 0.0

    def update(self, state, chunk):
        if self.key not in chunk.signals or len(chunk.time) == 0:
            return state
        values = chunk.signals[self.key][chunk.time > self.after_s]
        if values.size == 0 or np.all(np.isnan(values)):
            return state
        peak = float(np.nanmax(values))
        return peak if state is None else max(state, peak)

    def result(self, state) -> float:
        return float("nan") if state is None else float(state)


def _pointing(scenario) -> bool:
    return scenario.orbit is not None and scenario.stages["law"][0] == "pointing"


def _torquing(scenario) -> bool:
    return scenario.environment is not None and scenario.environment.magnetorquers is not None


POINTING_SETTLED = SettledNanMax("law/error_angle", after_s=60.0)


@metric("max_pointing_error_deg", applies=_pointing, uses=(POINTING_SETTLED,))
def max_pointing_error_deg(run) -> float:
    """max over t > 60 s of the pointing law's attitude error angle in its target frame [deg]."""
    return float(np.degrees(run.reduced(POINTING_SETTLED)))


def _dipole_use(scenario):
    limits = tuple(scenario.environment.magnetorquers.max_dipole_am2)
    return (DipoleUse("truth/magnetorquer_dipole", limits),)


@dataclass(frozen=True)
class DipoleUse(_OfSignal):
    """max over samples and axes of |m_i| / m_max,i of signal `key`."""

    limits: tuple = (1.0, 1.0, 1.0)

    def update(self, state, chunk):
        if self.key not in chunk.signals or len(chunk.time) == 0:
            return state
        peak = float(np.nanmax(np.abs(chunk.signals[self.key]) / np.asarray(self.limits)))
        return peak if state is None else max(state, peak)

    def result(self, state) -> float:
        return float(super().result(state))


@metric("peak_dipole_use", applies=_torquing, uses=_dipole_use)
def peak_dipole_use(run) -> float:
    """max_t max_i |m_i| / m_max,i: the magnetorquers' largest share of their dipole limit (<= 1)."""
    return run.reduced(_dipole_use(run.scenario)[0])
