"""Singularity-robust (damped) inverses: Nakamura & Hanafusa 1986 and Wie's generalized SR.

Both give beta' = J^T (J J^T + lambda E)^-1 H'/h, which trades a small momentum-rate error
for bounded gimbal rates near a singularity (the delivered h J beta' differs from H').

- "sr"  (Nakamura & Hanafusa 1986, ASME J. Dyn. Sys. 108): E = I and the damping grows as
  the singularity measure m = sqrt(det(J J^T)) falls below a threshold m0:
  lambda = lambda0 (1 - m/m0)^2 for m < m0, else 0 (then the law is the pseudo-inverse).
- "gsr" (Wie 2005, J. Guid. Control Dyn. 28(5), "Singularity escape/avoidance steering
  logic for CMG systems"): lambda = lambda0 exp(-mu det(J J^T)) and the symmetric matrix
  E = [[1, e3, e2], [e3, 1, e1], [e2, e1, 1]], e_i = epsilon0 sin(omega t + phi_i). The
  off-diagonal dither keeps (J J^T + lambda E)^-1 b from lying in the singular direction,
  so the command can escape internal singularities that plain SR cannot. Defaults are the
  values used in that paper (lambda0 = 0.01, mu = 10, epsilon0 = 0.01, omega = pi/2 rad/s,
  phases 0, pi/2, pi).
"""

from __future__ import annotations

import math

import numpy as np

from testbed.errors import InputError
from testbed.steering.least_squares import (DEFAULT_RCOND, jacobian_svd, min_norm_rows, min_norm_solution,
                                            numerical_rank)
from testbed.steering.result import SteeringResult, SteeringRows, limited_result, limited_rows
from testbed.math.validation import number_in, positive_number
from testbed.steering.validation import checked_problem, checked_rate_bounds


def nakamura_damping(m, lambda0: float, m0: float, minimum=min):
    """Nakamura-Hanafusa damping lambda0 (1 - m/m0)^2 below the threshold m0, else 0 (the square
    vanishes at m = m0); m a float, or an array of one per world with minimum = np.minimum."""
    return lambda0 * (1.0 - minimum(m, m0) / m0) ** 2


def wie_damping(det_jjt, lambda0: float, mu: float, exp=math.exp):
    """Wie's GSR damping lambda0 exp(-mu det(J J^T)) (never zero, largest at a singularity);
    det_jjt a float, or an array of one per world with exp = np.exp."""
    return lambda0 * exp(-mu * det_jjt)


def wie_dither_matrix(t: float, epsilon0: float, omega: float, phases) -> np.ndarray:
    """E(t) = [[1, e3, e2], [e3, 1, e1], [e2, e1, 1]], e_i = epsilon0 sin(omega t + phi_i).

    Positive definite for epsilon0 < 1/2 (Gershgorin), so J J^T + lambda E is invertible.
    """
    e1, e2, e3 = (epsilon0 * math.sin(omega * t + phi) for phi in phases)
    return np.array([[1.0, e3, e2], [e3, 1.0, e1], [e2, e1, 1.0]])


def damped_rates(J: np.ndarray, b: np.ndarray, damping, E: np.ndarray) -> np.ndarray:
    """beta' = J^T (J J^T + damping E)^-1 b (the SR / GSR inverse applied to b = H'/h): J (3, n),
    b (3,), damping a float; or a stack of worlds, J (N, 3, n), b (N, 3), damping (N,)."""
    if J.ndim == 2:  # one world: the 2-D products cost less than the stacked ones' broadcasting
        return J.T @ np.linalg.solve(J @ J.T + damping * E, b)
    Jt = np.swapaxes(J, -1, -2)
    gram = J @ Jt + np.asarray(damping)[..., None, None] * E
    return (Jt @ np.linalg.solve(gram, b[..., None]))[..., 0]


def sr_steering(J, h, Hdot, beta_rate_max, *, lambda0: float = 0.01, m0: float = 0.2,
                rcond: float = DEFAULT_RCOND, rate_bounds=None) -> SteeringResult:
    """Nakamura-Hanafusa SR-inverse rates, rate-limited (eq. 4).

    Where the damping is zero (m >= m0, or lambda0 = 0) this is exactly pinv_steering,
    including its least-squares treatment of a rank-deficient J. rate_bounds: optional
    per-gimbal (lo, hi) (rate_limit.apply_rate_bounds).
    """
    rows, h, hdot, beta_rate_max = checked_problem(J, h, Hdot, beta_rate_max)
    lambda0 = number_in("steering.lambda0", lambda0, 0.0, math.inf)
    m0 = positive_number("steering.m0", m0, allow_inf=False)
    rcond = number_in("steering.rcond", rcond, 0.0, 1.0, low_open=True, high_open=True)
    bounds = None if rate_bounds is None else checked_rate_bounds(rate_bounds, beta_rate_max, len(rows[0]))
    J = np.array(rows)
    b = np.array(hdot) / h
    svd = jacobian_svd(J, rcond)
    damping = nakamura_damping(svd.measure, lambda0, m0)
    # Undamped: the SVD pseudo-inverse, which also copes with rank < 3 when lambda0 = 0.
    beta_rate = damped_rates(J, b, damping, np.eye(3)) if damping > 0 else min_norm_solution(svd, b)
    return limited_result(J, h, beta_rate, beta_rate_max, svd.measure, svd.rank, bounds=bounds)


def checked_wie_options(t, lambda0, mu, epsilon0, omega, rcond) -> tuple[float, ...]:
    """The options Wie's laws share (gsr, osr), checked: t finite, lambda0 > 0, mu >= 0,
    0 <= epsilon0 < 1/2 (E positive definite), omega finite, 0 < rcond < 1; else InputError."""
    return (number_in("steering.t", t, -math.inf, math.inf, low_open=True, high_open=True),
            positive_number("steering.lambda0", lambda0, allow_inf=False),
            number_in("steering.mu", mu, 0.0, math.inf, high_open=True),
            number_in("steering.epsilon0", epsilon0, 0.0, 0.5, high_open=True),
            number_in("steering.omega", omega, -math.inf, math.inf, low_open=True, high_open=True),
            number_in("steering.rcond", rcond, 0.0, 1.0, low_open=True, high_open=True))


def gsr_steering(J, h, Hdot, beta_rate_max, *, t: float = 0.0, lambda0: float = 0.01,
                 mu: float = 10.0, epsilon0: float = 0.01, omega: float = math.pi / 2,
                 phases=(0.0, math.pi / 2, math.pi), rcond: float = DEFAULT_RCOND,
                 rate_bounds=None) -> SteeringResult:
    """Wie's generalized SR-inverse rates at time t [s], rate-limited (eq. 4).

    The damping is never zero, so J J^T + lambda E is invertible even at rank J < 3: no
    projection is made, the SR error absorbs the singularity (rcond only sets the reported rank).
    rate_bounds: optional per-gimbal (lo, hi) (rate_limit.apply_rate_bounds).
    """
    rows, h, hdot, beta_rate_max = checked_problem(J, h, Hdot, beta_rate_max)
    t, lambda0, mu, epsilon0, omega, rcond = checked_wie_options(t, lambda0, mu, epsilon0, omega, rcond)
    try:
        phases = tuple(float(p) for p in phases)
    except (TypeError, ValueError):
        phases = ()
    if len(phases) != 3 or not all(map(math.isfinite, phases)):
        raise InputError("steering.phases", "must be 3 finite angles [rad]")
    bounds = None if rate_bounds is None else checked_rate_bounds(rate_bounds, beta_rate_max, len(rows[0]))
    J = np.array(rows)
    svd = jacobian_svd(J, rcond)
    E = wie_dither_matrix(t, epsilon0, omega, phases)
    damping = wie_damping(svd.measure ** 2, lambda0, mu)
    beta_rate = damped_rates(J, np.array(hdot) / h, damping, E)
    return limited_result(J, h, beta_rate, beta_rate_max, svd.measure, svd.rank, bounds=bounds)


def sr_steering_rows(J, h, hdot, beta_rate_max, *, lambda0: float, m0: float, rcond: float,
                     rate_bounds=None) -> SteeringRows:
    """`sr_steering` of N worlds, a row each: J (N, 3, n), h (N,) [N m s], hdot (N, 3) [N m],
    beta_rate_max (N,) [rad/s], rate_bounds None or (lo, hi) (N, n) each; finite inputs and
    options already checked (testbed.batch)."""
    b = hdot / h[:, None]
    u, s, vt = np.linalg.svd(J, full_matrices=True)
    measure = np.prod(s, axis=-1)
    beta_rate, rank = min_norm_rows(u, s, vt, b, rcond)
    damping = nakamura_damping(measure, lambda0, m0, np.minimum)
    damped = damping > 0  # only those: an undamped singular J J^T has no inverse
    if damped.any():
        beta_rate[damped] = damped_rates(J[damped], b[damped], damping[damped], np.eye(3))
    return limited_rows(J, h, beta_rate, beta_rate_max, measure, rank, rate_bounds)


def gsr_steering_rows(J, h, hdot, beta_rate_max, *, t: float, lambda0: float, mu: float, epsilon0: float,
                      omega: float, phases, rcond: float, rate_bounds=None) -> SteeringRows:
    """`gsr_steering` of N worlds at time t [s], a row each (as `sr_steering_rows`)."""
    s = np.linalg.svd(J, compute_uv=False)
    measure = np.prod(s, axis=-1)
    beta_rate = damped_rates(J, hdot / h[:, None], wie_damping(measure ** 2, lambda0, mu, np.exp),
                             wie_dither_matrix(t, epsilon0, omega, phases))
    return limited_rows(J, h, beta_rate, beta_rate_max, measure, numerical_rank(s, rcond), rate_bounds)
