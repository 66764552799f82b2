"""Metrics of the `mekf` estimator, from the trace: the true estimation errors (truth/quat
against estimator/quat, sensor/gyro_bias against estimator/bias) after the filter's
`settle_s`, their NEES against its covariance, and the bias inside its 3σ bounds. The last
trace row holds only the truth; rows without an estimate are left out."""

from __future__ import annotations

import numpy as np

from testbed.math.quaternion import quat_conj, quat_mul
from testbed.metrics import metric

ARCSEC = np.pi / (180.0 * 3600.0)
ATTITUDE = ("truth/quat", "estimator/quat", "estimator/covariance")
BIAS = ("sensor/gyro_bias", "estimator/bias", "estimator/bias_sigma3")


def _filtered(scenario) -> bool:
    return scenario.stages["estimator"][0] == "mekf"


def attitude_errors(truth_quat, estimated_quat) -> np.ndarray:
    """δθ = 2 vec(q̂~ ∘ q) (short way) per row [rad, body axes]: the filter's error state."""
    error = quat_mul(quat_conj(estimated_quat), truth_quat)
    return 2.0 * error[:, 1:] * np.where(error[:, :1] < 0, -1.0, 1.0)


def attitude_nees(errors, covariance_rows) -> np.ndarray:
    """δθᵀ P_θθ⁻¹ δθ per row, P_θθ the attitude block of the recorded 6 x 6 covariance."""
    blocks = covariance_rows.reshape(-1, 6, 6)[:, :3, :3]
    return np.einsum("ni,ni->n", errors, np.linalg.solve(blocks, errors[..., None])[..., 0])


def _settled(run, keys):
    """The rows after the filter's settle_s that hold every key, and those keys' rows."""
    values = [run.recorder[key] for key in keys]
    rows = (run.recorder.time >= run.statistics["estimator"]["settle_s"]) & np.all(
        [np.all(np.isfinite(v), axis=1) for v in values], axis=0)
    return [v[rows] for v in values]


@metric("attitude_knowledge_error_arcsec", applies=_filtered, uses=ATTITUDE[:2])
def attitude_knowledge_error_arcsec(run) -> float:
    """RMS over the samples after settle_s of the angle between the true and the estimated attitude [arcsec]."""
    truth, estimate = _settled(run, ATTITUDE[:2])
    return float(np.sqrt(np.mean(np.sum(attitude_errors(truth, estimate) ** 2, axis=1))) / ARCSEC)


@metric("attitude_nees_mean", applies=_filtered, uses=ATTITUDE)
def attitude_nees_mean(run) -> float:
    """Mean over the samples after settle_s of the attitude NEES δθᵀ P_θθ⁻¹ δθ (3 for a consistent filter)."""
    truth, estimate, covariance = _settled(run, ATTITUDE)
    return float(np.mean(attitude_nees(attitude_errors(truth, estimate), covariance)))


@metric("final_attitude_nees", applies=_filtered, uses=ATTITUDE)
def final_attitude_nees(run) -> float:
    """The attitude NEES at the last estimated sample (a campaign's mean over seeds: χ²(3 n) / n)."""
    truth, estimate, covariance = _settled(run, ATTITUDE)
    return float(attitude_nees(attitude_errors(truth[-1:], estimate[-1:]), covariance[-1:])[0])


@metric("bias_within_3sigma_fraction", applies=_filtered, uses=BIAS)
def bias_within_3sigma_fraction(run) -> float:
    """Fraction of the samples after settle_s whose bias estimate lies within its 3σ bound on every axis."""
    truth, estimate, bound = _settled(run, BIAS)
    return float(np.mean(np.all(np.abs(estimate - truth) <= bound, axis=1)))
