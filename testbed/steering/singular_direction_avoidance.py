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
from testbed.steering.least_squares import DEFAULT_RCOND, numerical_rank
from testbed.steering.result import SteeringResult, SteeringRows, limited_result, limited_rows
from testbed.steering.validation import checked_problem, checked_rate_bounds


def sda_gains(s: np.ndarray, lambda0: float, mu: float, rcond: float) -> np.ndarray:
    """The inverse singular values of SDA: 1/s_k for k < 3 (0 at or below rcond s_1), and
    s_3 / (s_3^2 + lambda0 exp(-mu s_3^2)) for the smallest (Ford & Hall 2000); s (3,)."""
    gains = np.zeros_like(s)
    kept = s[:-1] > rcond * s[0]
    gains[:-1][kept] = 1.0 / s[:-1][kept]
    last = s[-1]
    denominator = damped_square(last, lambda0, mu, math.exp)
    gains[-1] = last / denominator if denominator > 0 else 0.0
    return gains


def sda_gains_rows(s: np.ndarray, lambda0: float, mu: float, rcond: float) -> np.ndarray:
    """`sda_gains` of N worlds' singular values s (N, 3), a row each."""
    gains = np.zeros_like(s)
    np.divide(1.0, s[:, :-1], out=gains[:, :-1], where=s[:, :-1] > rcond * s[:, :1])
    denominator = damped_square(s[:, -1], lambda0, mu, np.exp)
    np.divide(s[:, -1], denominator, out=gains[:, -1], where=denominator > 0)
    return gains


def damped_square(last, lambda0: float, mu: float, exp):
    """s_3^2 + lambda0 exp(-mu s_3^2): the damped square of the smallest singular value (Ford & Hall
    2000, scheduled as Wie's); a float with exp = math.exp, an array with np.exp."""
    return last * last + lambda0 * exp(-mu * last * last)


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
    return limited_result(J, h, beta_rate, beta_rate_max, float(np.prod(s)), numerical_rank(s, rcond), bounds=bounds)


def sda_steering_rows(J, h, hdot, beta_rate_max, *, lambda0: float, mu: float, rcond: float,
                      rate_bounds=None) -> SteeringRows:
    """`sda_steering` of N worlds, a row each: J (N, 3, n), h (N,) [N m s], hdot (N, 3) [N m],
    beta_rate_max (N,) [rad/s], rate_bounds None or (lo, hi) (N, n) each; finite inputs and
    options already checked (testbed.batch)."""
    u, s, vt = np.linalg.svd(J, full_matrices=False)
    b = hdot / h[:, None]
    along = (b[:, None, :] @ u)[:, 0, :] * sda_gains_rows(s, lambda0, mu, rcond)
    beta_rate = (along[:, None, :] @ vt)[:, 0, :]
    return limited_rows(J, h, beta_rate, beta_rate_max, np.prod(s, axis=-1), numerical_rank(s, rcond),
                        rate_bounds)
