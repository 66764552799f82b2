"""Pointing metrics of the regulation laws (quaternion_feedback, mrp_feedback), from the truth:
the angle between the bus attitude and the law's target."""

from __future__ import annotations

import numpy as np

from testbed.math.quaternion import quat_angle, quat_conj, quat_mul
from testbed.metrics import metric

JITTER_WINDOW_S = 20.0
LAWS = ("quaternion_feedback", "mrp_feedback")


def _regulated(scenario) -> bool:
    return scenario.stages["law"][0] in LAWS


def _pointing_error(run) -> np.ndarray:
    return quat_angle(quat_mul(quat_conj(run.statistics["law"]["target_quat"]), run.recorder["truth/quat"]))


@metric("final_pointing_error_deg", applies=_regulated, uses=("truth/quat",))
def final_pointing_error_deg(run) -> float:
    """Angle between the final bus attitude and the law's target [deg]."""
    return float(np.degrees(_pointing_error(run)[-1]))


@metric("pointing_rms_last_20s_arcsec", applies=_regulated, uses=("truth/quat",))
def pointing_rms_last_20s_arcsec(run) -> float:
    """RMS of the angle between the bus attitude and the target over the run's last 20 s [arcsec]."""
    time = run.recorder.time
    last = time >= time[-1] - JITTER_WINDOW_S
    return float(np.degrees(np.sqrt(np.mean(_pointing_error(run)[last] ** 2))) * 3600.0)
