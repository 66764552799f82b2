"""Vadali's preferred-gimbal-angle null motion (Vadali, Oh & Walker 1990, J. Guid. Control Dyn.
13(6), 1090-1095, "Preferred gimbal angles for single gimbal control moment gyros"):

    beta' = J^+ b + k (I - J^+ J)(beta^p - beta),   b = H'/h,

the pseudo-inverse rates (eq. 20, pseudo_inverse.py) plus the null motion that drives the gimbals
towards the preferred set beta^p. The paper computes beta^p before the manoeuvre (by integrating the
manoeuvre's momentum path backwards) so that the path it then flies avoids singular states; the
testbed takes the run's starting angles (`preferred_gimbal_angles`), which for a rest-to-rest slew
from a zero-momentum set is the set the slew should end on. The null motion produces no torque
(J (I - J^+ J) = 0), so the torque is the pseudo-inverse's. The angle error is wrapped to (-pi, pi].
"""

from __future__ import annotations

import math

import numpy as np

from testbed.math.validation import number_in
from testbed.steering.least_squares import DEFAULT_RCOND, jacobian_svd, min_norm_solution
from testbed.steering.result import SteeringResult, limited_result
from testbed.steering.validation import checked_problem, checked_rate_bounds


def pga_steering(J, h, Hdot, beta_rate_max, *, gimbal_angle=None, preferred_gimbal_angles=None,
                 null_gain_per_s: float = 0.5, rcond: float = DEFAULT_RCOND, rate_bounds=None) -> SteeringResult:
    """Pseudo-inverse rates plus Vadali's null motion towards the preferred (starting) angles (module
    doc), rate-limited (eq. 4); options: null_gain_per_s = 0.5 (k [1/s]), rcond.

    Without angles (or with k = 0) it is pinv_steering."""
    rows, h, hdot, beta_rate_max = checked_problem(J, h, Hdot, beta_rate_max)
    gain = number_in("steering.null_gain_per_s", null_gain_per_s, 0.0, math.inf, high_open=True)
    rcond = number_in("steering.rcond", rcond, 0.0, 1.0, low_open=True, high_open=True)
    bounds = None if rate_bounds is None else checked_rate_bounds(rate_bounds, beta_rate_max, len(rows[0]))
    J = np.array(rows)
    svd = jacobian_svd(J, rcond)
    beta_rate = min_norm_solution(svd, np.array(hdot) / h)
    if gain > 0 and gimbal_angle is not None and preferred_gimbal_angles is not None:
        error = np.angle(np.exp(1j * (np.asarray(preferred_gimbal_angles, float) - np.asarray(gimbal_angle, float))))
        beta_rate = beta_rate + gain * (svd.null_space.T @ (svd.null_space @ error))
    return limited_result(J, h, beta_rate, beta_rate_max, svd.measure, svd.rank, bounds=bounds)
