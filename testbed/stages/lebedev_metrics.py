"""Metrics of the Lebedev one-gyro spin control runs (issue 4): spin error, estimation error.

The spin target is w* = (0, 0, Omega) (Task 1) or (0, 0, Omega*) (Task 2), Lebedev 1976,
eq. 4.1 and section 5. Estimation errors compare the estimator's `omega` with the truth at
the same trace samples: evaluation after the run, never fed back. Rates are in deg/s, as the
paper reports them. "Steady" means the last STEADY_FRACTION of the run. The CMG-actuated runs
use the steering metrics of testbed.stages.steering_metrics (rate_limit_violations, ...).
"""

from __future__ import annotations

import numpy as np

from testbed.metrics import metric

STEADY_FRACTION = 0.2
FINAL_FRACTION = 0.1


def _law_is_lebedev(scenario) -> bool:
    return scenario.stages["law"][0] == "lebedev"


def _estimator_is_lebedev(scenario) -> bool:
    return scenario.stages["estimator"][0] == "lebedev"


def _is_detumble(scenario) -> bool:
    return _law_is_lebedev(scenario) and scenario.stages["law"][1].task == "detumble"


def _target(run) -> np.ndarray:
    return np.array([0.0, 0.0, run.scenario.stages["law"][1].omega_ref])


def _tail(run, fraction: float) -> np.ndarray:
    """Boolean mask of the samples in the last `fraction` of the run."""
    t = run.recorder.time
    return t >= t[-1] - fraction * (t[-1] - t[0])


def _spin_error(run) -> np.ndarray:
    return np.degrees(run.recorder["truth/omega"] - _target(run))


def _estimation_error(run) -> np.ndarray:
    """|w_hat - w| [deg/s] per trace sample (NaN where the estimator did not run)."""
    estimate = run.recorder["estimator/omega_estimate"]
    return np.degrees(np.linalg.norm(estimate - run.recorder["truth/omega"], axis=1))


@metric("spin_error_final_deg_s", applies=_law_is_lebedev)
def spin_error_final_deg_s(run) -> float:
    """|w(T) - (0, 0, Omega)| at the end of the run [deg/s] (Lebedev 1976, eq. 4.1)."""
    return float(np.linalg.norm(_spin_error(run)[-1]))


@metric("spin_error_steady_deg_s", applies=_law_is_lebedev)
def spin_error_steady_deg_s(run) -> float:
    """Mean of |w - (0, 0, Omega)| over the last 20 % of the run [deg/s]."""
    return float(np.mean(np.linalg.norm(_spin_error(run)[_tail(run, STEADY_FRACTION)], axis=1)))


@metric("spin_rate_offset_deg_s", applies=_law_is_lebedev)
def spin_rate_offset_deg_s(run) -> float:
    """Mean of w_z - Omega over the last 20 % of the run [deg/s] (a gyro bias b gives -b / gamma)."""
    return float(np.mean(_spin_error(run)[_tail(run, STEADY_FRACTION), 2]))


@metric("transverse_rate_steady_deg_s", applies=_law_is_lebedev)
def transverse_rate_steady_deg_s(run) -> float:
    """RMS of sqrt(w_x^2 + w_y^2) over the last 20 % of the run [deg/s] (nutation left)."""
    e = _spin_error(run)[_tail(run, STEADY_FRACTION), :2]
    return float(np.sqrt(np.mean(np.sum(e**2, axis=1))))


@metric("peak_body_rate_deg_s", applies=_law_is_lebedev)
def peak_body_rate_deg_s(run) -> float:
    """max over the run of |w| [deg/s]: stays near max(|w(0)|, Omega) when the loop is stable."""
    return float(np.degrees(np.max(np.linalg.norm(run.recorder["truth/omega"], axis=1))))


@metric("residual_rate_final_deg_s", applies=_is_detumble)
def residual_rate_final_deg_s(run) -> float:
    """|w(T)| after detumbling [deg/s]; Task 2 leaves the admissible residual Omega* (section 5)."""
    return float(np.degrees(np.linalg.norm(run.recorder["truth/omega"][-1])))


@metric("estimation_error_startup_deg_s", applies=_estimator_is_lebedev)
def estimation_error_startup_deg_s(run) -> float:
    """max |w_hat - w| during the start-up phase, t < startup_s [deg/s] (z(0) = 0, so it is > 0)."""
    startup = run.scenario.stages["estimator"][1].startup_s
    err = _estimation_error(run)[run.recorder.time < startup]
    return float(np.nanmax(err)) if err.size else float("nan")


@metric("estimation_error_at_closing_deg_s", applies=_estimator_is_lebedev)
def estimation_error_at_closing_deg_s(run) -> float:
    """|w_hat - w| at the first sample with t >= startup_s, when control begins [deg/s]."""
    startup = run.scenario.stages["estimator"][1].startup_s
    after = np.flatnonzero(run.recorder.time >= startup)
    return float(_estimation_error(run)[after[0]]) if after.size else float("nan")


@metric("estimation_error_final_deg_s", applies=_estimator_is_lebedev)
def estimation_error_final_deg_s(run) -> float:
    """max |w_hat - w| over the last 10 % of the run [deg/s]."""
    return float(np.nanmax(_estimation_error(run)[_tail(run, FINAL_FRACTION)]))


def _has_continuous_reference(scenario) -> bool:
    return scenario.reference is not None and scenario.reference[0] == "lebedev_continuous"


@metric("max_deviation_from_continuous_deg_s", applies=_has_continuous_reference)
def max_deviation_from_continuous_deg_s(run) -> float:
    """max over trace samples of |w - w_c|, w_c the continuous-time closed loop (reference lebedev_continuous) [deg/s]."""
    if run.reference_error:
        raise ValueError(run.reference_error)
    return float(np.degrees(np.max(np.linalg.norm(run.recorder["reference/omega_error"], axis=1))))
