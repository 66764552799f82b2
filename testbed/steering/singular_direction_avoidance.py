"""Ford and Hall's singular-direction avoidance (SDA; Ford & Hall 2000, J. Guid. Control Dyn. 23(4),
648-656, "Singular direction avoidance steering for control-moment gyros"):

    J = U diag(s_1, s_2, s_3) V^T,   beta' = V diag(1/s_1, 1/s_2, s_3 / (s_3^2 + lambda)) U^T b.

Only the smallest singular value is damped: the demand's component along the singular direction
u_3 is delivered with the gain s_3^2 / (s_3^2 + lambda) < 1, the other two exactly, so the error
lies along u_3 alone (the SR inverse, sr_inverse.py, damps all three). Here the damping is
scheduled like Wie's, lambda = lambda0 exp(-mu s_3^2), so that away from a singular set the law is
the pseudo-inverse (mu = 0: the constant lambda0). Singular values other than the last at or below
rcond s_1 are dropped (the least-squares treatment of pinv, least_squares.py).
"""

from __future__ import annotations

import math

import numpy as np

from testbed.math.validation import number_in
from testbed.steering.least_squares import DEFAULT_RCOND
from testbed.steering.result import SteeringResult, limited_result
from testbed.steering.validation import checked_problem, checked_rate_bounds


def sda_gains(s: np.ndarray, lambda0: float, mu: float, rcond: float) -> np.ndarray:
    """The inverse singular values of SDA: 1/s_k for k < 3 (0 at or below rcond s_1), and
    s_3 / (s_3^2 + lambda0 exp(-mu s_3^2)) for the smallest (Ford & Hall 2000)."""
    gains = np.zeros_like(s)
    kept = s[:-1] > rcond * s[0]
    gains[:-1][kept] = 1.0 / s[:-1][kept]
    last = s[-1]
    damping = lambda0 * math.exp(-mu * last * last)
    gains[-1] = last / (last * last + damping) if last * last + damping > 0 else 0.0
    return gains


def sda_steering(J, h, Hdot, beta_rate_max, *, lambda0: float = 0.01, mu: float = 10.0,
                 rcond: float = DEFAULT_RCOND, rate_bounds=None) -> SteeringResult:
    """Ford and Hall's singular-direction-avoidance rates (module doc), rate-limited (eq. 4); options:
    lambda0 = 0.01, mu = 10 (lambda = lambda0 exp(-mu s_3^2)), rcond.

    rate_bounds: optional per-gimbal (lo, hi) (rate_limit.apply_rate_bounds)."""
    rows, h, hdot, beta_rate_max = checked_problem(J, h, Hdot, beta_rate_max)
    lambda0 = number_in("steering.lambda0", lambda0, 0.0, math.inf, high_open=True)
    mu = number_in("steering.mu", mu, 0.0, math.inf, high_open=True)
    rcond = number_in("steering.rcond", rcond, 0.0, 1.0, low_open=True, high_open=True)
    bounds = None if rate_bounds is None else checked_rate_bounds(rate_bounds, beta_rate_max, len(rows[0]))
    J = np.array(rows)
    u, s, vt = np.linalg.svd(J, full_matrices=False)
    beta_rate = vt.T @ (sda_gains(s, lambda0, mu, rcond) * (u.T @ (np.array(hdot) / h)))
    rank = int(np.count_nonzero(s > rcond * s[0])) if s[0] > 0 else 0
    return limited_result(J, h, beta_rate, beta_rate_max, float(np.prod(s)), rank, bounds=bounds)
