"""Wie's off-diagonal singularity-robust inverse (Wie 2005, J. Guid. Control Dyn. 28(5), 948-956,
"Singularity escape/avoidance steering logic for control moment gyro systems", eq. (25)-(27)):

    beta' = W J^T (J W J^T + lambda E)^-1 b,   b = H'/h,   lambda = lambda0 exp(-mu det(J J^T)),

    W = [[w_1, lambda, lambda, lambda], ..., [lambda, lambda, lambda, w_4]]   (off-diagonal lambda),
    E = [[1, e3, e2], [e3, 1, e1], [e2, e1, 1]],   e_i = epsilon0 sin(omega t + phi_i).

The off-diagonal terms of W mix the gimbals' rates, those of E keep (J W J^T + lambda E)^-1 b out of
the singular direction: together they let the command leave a singular state, where the plain
pseudo-inverse gives zero rates for a demand along the singular direction (docs/theory/steering.md
"Published laws"). `gsr` (sr_inverse.py) is the same law with W = I. Defaults: NASA 42's
(lambda0 = 0.01, mu = 10, epsilon0 = 0.1, omega = 1 rad/s, phases 0, pi/2, pi, w_i = 1).
"""

from __future__ import annotations

import math

import numpy as np

from testbed.errors import InputError
from testbed.math.validation import positive_number
from testbed.steering.least_squares import DEFAULT_RCOND, jacobian_svd, numerical_rank
from testbed.steering.result import SteeringResult, SteeringRows, limited_result, limited_rows
from testbed.steering.sr_inverse import checked_wie_options, wie_damping, wie_dither_matrix
from testbed.steering.validation import checked_problem, checked_rate_bounds

PHASES = (0.0, math.pi / 2, math.pi)


def off_diagonal_weights(damping, weight: float, gimbals: int) -> np.ndarray:
    """W of Wie 2005 eq. (26): `weight` on the diagonal, the damping lambda everywhere else;
    (gimbals, gimbals), or (N, gimbals, gimbals) for a damping (N,) of one per world."""
    if np.ndim(damping) == 0:  # one world: one fill costs less than the broadcast below
        return np.full((gimbals, gimbals), damping) + (weight - damping) * np.eye(gimbals)
    damping = np.asarray(damping)[..., None, None]
    return damping * np.ones((gimbals, gimbals)) + (weight - damping) * np.eye(gimbals)


def off_diagonal_rates(J, b, damping, weight: float, E: np.ndarray) -> np.ndarray:
    """beta' = W J^T (J W J^T + lambda E)^-1 b (eq. 25): J (3, n), b (3,), damping a float; or a
    stack of worlds, J (N, 3, n), b (N, 3), damping (N,)."""
    W = off_diagonal_weights(damping, weight, J.shape[-1])
    if J.ndim == 2:  # one world: the 2-D products cost less than the stacked ones' broadcasting
        return W @ J.T @ np.linalg.solve(J @ W @ J.T + damping * E, b)
    WJt = W @ np.swapaxes(J, -1, -2)
    gram = J @ WJt + np.asarray(damping)[..., None, None] * E
    return (WJt @ np.linalg.solve(gram, b[..., None]))[..., 0]


def osr_steering(J, h, Hdot, beta_rate_max, *, t: float = 0.0, lambda0: float = 0.01, mu: float = 10.0,
                 epsilon0: float = 0.1, omega: float = 1.0, weight: float = 1.0, rcond: float = DEFAULT_RCOND,
                 rate_bounds=None) -> SteeringResult:
    """Wie's off-diagonal SR rates at time t [s] (module doc, Wie 2005 eq. (25)-(27)), rate-limited;
    options: lambda0 = 0.01, mu = 10, epsilon0 = 0.1 (< 0.5), omega = 1 rad/s, weight = 1 (> lambda0), rcond.

    The damping never vanishes, so J W J^T + lambda E is invertible at any rank (rcond only sets the
    reported rank). rate_bounds: optional per-gimbal (lo, hi) (rate_limit.apply_rate_bounds).
    """
    rows, h, hdot, beta_rate_max = checked_problem(J, h, Hdot, beta_rate_max)
    t, lambda0, mu, epsilon0, omega, rcond = checked_wie_options(t, lambda0, mu, epsilon0, omega, rcond)
    weight = positive_number("steering.weight", weight, allow_inf=False)
    if weight <= lambda0:
        raise InputError("steering.weight", f"must exceed lambda0 = {lambda0:g} (W positive definite)")
    bounds = None if rate_bounds is None else checked_rate_bounds(rate_bounds, beta_rate_max, len(rows[0]))
    J = np.array(rows)
    svd = jacobian_svd(J, rcond)
    beta_rate = off_diagonal_rates(J, np.array(hdot) / h, wie_damping(svd.measure ** 2, lambda0, mu), weight,
                                   wie_dither_matrix(t, epsilon0, omega, PHASES))
    return limited_result(J, h, beta_rate, beta_rate_max, svd.measure, svd.rank, bounds=bounds)


def osr_steering_rows(J, h, hdot, beta_rate_max, *, t: float, lambda0: float, mu: float, epsilon0: float,
                      omega: float, weight: float, rcond: float, rate_bounds=None) -> SteeringRows:
    """`osr_steering` of N worlds at time t [s], a row each: J (N, 3, n), h (N,) [N m s], hdot (N, 3)
    [N m], beta_rate_max (N,) [rad/s], rate_bounds None or (lo, hi) (N, n) each; finite inputs and
    options already checked (testbed.batch)."""
    s = np.linalg.svd(J, compute_uv=False)
    measure = np.prod(s, axis=-1)
    beta_rate = off_diagonal_rates(J, hdot / h[:, None], wie_damping(measure ** 2, lambda0, mu, np.exp), weight,
                                   wie_dither_matrix(t, epsilon0, omega, PHASES))
    return limited_rows(J, h, beta_rate, beta_rate_max, measure, numerical_rank(s, rcond), rate_bounds)
