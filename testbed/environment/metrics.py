"""Metrics of a run in orbit: the pointing error in the target frame and the magnetorquers'
use of their dipole limits (running reductions: a 10-orbit run keeps no history)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.environment.libration import fitted_frequencies, lvlh_angles, pitch_frequency, roll_yaw_frequencies
from testbed.metrics import metric
from testbed.orbit.config import circular_rate
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


@dataclass(frozen=True)
class SettledAngleBetween(_OfSignal):
    """max over the samples after `after_s` [s] of the rotation angle [rad] between the
    attitudes (w, x, y, z) of signals `key` and `other`: 2 atan2(|v|, |w|) of q_key^-1 q_other."""

    other: str = ""
    after_s: float = 0.0

    def update(self, state, chunk):
        if self.key not in chunk.signals or self.other not in chunk.signals or len(chunk.time) == 0:
            return state
        late = chunk.time > self.after_s
        a, b = chunk.signals[self.key][late], chunk.signals[self.other][late]
        if len(a) == 0:
            return state
        dot = np.abs(np.sum(a * b, axis=1))   # |w| of q_a^-1 q_b: the cosine of half the angle
        sine = np.linalg.norm(a[:, :1] * b[:, 1:] - b[:, :1] * a[:, 1:] - np.cross(a[:, 1:], b[:, 1:]), axis=1)
        angles = 2.0 * np.arctan2(sine, dot)
        angles = angles[np.isfinite(angles)]   # rows where one of the two was not recorded
        if angles.size == 0:
            return state
        peak = float(np.max(angles))
        return peak if state is None else max(state, peak)

    def result(self, state) -> float:
        return float("nan") if state is None else float(state)


TRUE_POINTING_SETTLED = SettledAngleBetween("truth/quat", other="law/target_quat", after_s=60.0)


@metric("max_true_pointing_error_deg", applies=_pointing, uses=(TRUE_POINTING_SETTLED,))
def max_true_pointing_error_deg(run) -> float:
    """max over t > 60 s of the angle between the true attitude and the law's target [deg] (the
    law's own error is against its estimate: max_pointing_error_deg)."""
    return float(np.degrees(run.reduced(TRUE_POINTING_SETTLED)))


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


def _librating(scenario) -> bool:
    """An uncontrolled rigid body of principal inertia under the gravity gradient alone, on a
    Keplerian circular orbit: the case the closed forms describe."""
    o, e = scenario.orbit, scenario.environment
    return (o is not None and o.tle is None and o.eccentricity == 0.0 and not o.j2 and e is not None
            and e.gravity_gradient and e.drag is None and e.solar_pressure is None and e.magnetic_field is None
            and scenario.stages["law"][0] == "none" and hasattr(scenario.model, "inertia_kg_m2"))


def _libration(run):
    """(the measured, the closed-form) pitch and roll-yaw frequencies of the run [rad/s]."""
    t = run.recorder.time
    roll, pitch, yaw = lvlh_angles(run.recorder["truth/quat_lvlh"]).T
    inertia = run.scenario.model.inertia_kg_m2
    n = circular_rate(run.scenario.orbit.semi_major_axis_km * 1e3)
    return ((fitted_frequencies(t, [pitch], 1), fitted_frequencies(t, [roll, yaw], 2)),
            (pitch_frequency(inertia, n), roll_yaw_frequencies(inertia, n)))


@metric("pitch_libration_error_rel", applies=_librating, uses=("truth/quat_lvlh",))
def pitch_libration_error_rel(run) -> float:
    """|w_pitch / (n sqrt(3 (Ix - Iz) / Iy)) - 1|: the fitted pitch libration against its closed form."""
    (pitch, _), (expected, _) = run.shared("libration", lambda: _libration(run))
    return float(abs(pitch[0] / expected - 1.0))


@metric("roll_yaw_libration_error_rel", applies=_librating, uses=("truth/quat_lvlh",))
def roll_yaw_libration_error_rel(run) -> float:
    """max over the two roll-yaw modes of |w_fit / w_closed_form - 1| (Wie eq. 7.25)."""
    (_, roll_yaw), (_, expected) = run.shared("libration", lambda: _libration(run))
    return float(np.max(np.abs(roll_yaw / expected - 1.0)))
