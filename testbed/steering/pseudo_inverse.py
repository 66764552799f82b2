"""Pseudo-inverse steering, SEEDS §004 eq. (20) corrected: beta' = J^T (J J^T)^-1 H'/h.

The paper writes (L^T L)^-1 L^T, which is singular for a 3x4 L; the minimum-norm solution
of the under-determined eq. (17) is J^T (J J^T)^-1 b. It is evaluated through the SVD so a
singular J gives the minimum-norm least-squares rates instead of inf/nan.
"""

from __future__ import annotations

import numpy as np

from testbed.steering.least_squares import DEFAULT_RCOND, jacobian_svd, min_norm_rows, min_norm_solution
from testbed.steering.result import SteeringResult, SteeringRows, limited_result, limited_rows
from testbed.math.validation import number_in
from testbed.steering.validation import checked_problem, checked_rate_bounds


def pinv_steering(J, h, Hdot, beta_rate_max, *, rcond: float = DEFAULT_RCOND, rate_bounds=None) -> SteeringResult:
    """Minimum-norm gimbal rates for h J beta' = H' (eq. 17, 20), rate-limited (eq. 4).

    Rank < 3 (singular values <= rcond * sigma_max): the least-squares projection of H'
    onto range(J) is delivered instead, still with the minimum-norm rates. rate_bounds:
    optional per-gimbal (lo, hi) (rate_limit.apply_rate_bounds).
    """
    rows, h, hdot, beta_rate_max = checked_problem(J, h, Hdot, beta_rate_max)
    rcond = number_in("steering.rcond", rcond, 0.0, 1.0, low_open=True, high_open=True)
    bounds = None if rate_bounds is None else checked_rate_bounds(rate_bounds, beta_rate_max, len(rows[0]))
    J = np.array(rows)
    svd = jacobian_svd(J, rcond)
    beta_rate = min_norm_solution(svd, np.array(hdot) / h)
    return limited_result(J, h, beta_rate, beta_rate_max, svd.measure, svd.rank, bounds=bounds)


def pinv_steering_rows(J, h, hdot, beta_rate_max, *, rcond: float, rate_bounds=None) -> SteeringRows:
    """`pinv_steering` of N worlds, a row each: J (N, 3, n), h (N,) [N m s], hdot (N, 3) [N m],
    beta_rate_max (N,) [rad/s], rate_bounds None or (lo, hi) (N, n) each; finite inputs and
    options already checked (testbed.batch)."""
    u, s, vt = np.linalg.svd(J, full_matrices=True)
    beta_rate, rank = min_norm_rows(u, s, vt, hdot / h[:, None], rcond)
    return limited_rows(J, h, beta_rate, beta_rate_max, np.prod(s, axis=-1), rank, rate_bounds)
