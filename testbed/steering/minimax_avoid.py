"""Singularity-avoiding min-max steering: min-max rates, a barrier on sqrt(det(J J^T)) and a pull
back to the start's zero-momentum family, all along the null vector (exact torque).

The min-max law (SEEDS §004 eq. (21)-(28), minimax_exact.py) spends the one free direction of
a rank-3, 3x4 J on the lowest peak rate and nothing else; on reorient_near_singular it steers
into a singular set. This law keeps that optimum where it decides the run's peak rate and spends
the free direction elsewhere on two things: a barrier that keeps the singularity measure
m = sqrt(det(J J^T)) away from zero now, and a pull towards the zero-momentum family of the
configuration the run started from, so that the slew ends there and not on a singular
zero-momentum set. With b = H'/h (eq. 17):

1. Solutions. Thin SVD J = U diag(s_1, s_2, s_3) V^T (s_1 >= s_2 >= s_3 > 0) and v_4 the unit
   null vector: every solution of J beta' = b is

       beta'(t) = x + t v_4,   x = V diag(1/s) U^T b  (minimum norm, eq. 20),  t real.      (1)

2. Bounds. lo <= beta'(t) <= hi, with [lo_i, hi_i] = [-beta'max, beta'max] intersected with the
   caller's per-gimbal `rate_bounds` (angle and acceleration limits, gimbal_limits.py), is an
   interval of t:  T = [max_i t_i^-, min_i t_i^+],  t_i^-+ = the ends of
   (lo_i - x_i)/v_4i .. (hi_i - x_i)/v_4i (for v_4i = 0: all t if lo_i <= x_i <= hi_i, else none).

3. Barrier. m = s_1 s_2 s_3, and the singular values move as ds_k = u_k^T dJ v_k. Column i of J
   depends on beta_i alone (a single-gimbal CMG), so with d_i = dJ_i/dbeta_i (`column_derivative`,
   the negative spin axis of CMG i):

       dm/dbeta_i = g_i = sum_k (m / s_k) (u_k . d_i) V_ik,   dm/dt = g . beta'.               (2)

   (m / s_k is the product of the other two singular values, so (2) stays finite as s_3 -> 0.)
   The barrier asks for

       g . beta'(t) >= -gamma (m - m_floor)                                                    (3)

   (`barrier_gain_per_s` = gamma, `measure_floor` = m_floor): while it holds, m - m_floor decays at
   most like exp(-gamma t), so m does not cross m_floor; below it, (3) asks for a recovery at the
   rate gamma (m_floor - m). Far from a singular set the right side is very negative and (3) is
   inactive. In t, (3) is the half-line A = {t : (g . v_4) t >= -gamma (m - m_floor) - g . x}.

4. Why (3) alone is not enough. On a rest-to-rest slew about one body axis, H = -I omega runs out
   along a ray and back to zero. A law beta' = F(beta, H') that is odd and homogeneous of degree 1
   in H' (pinv, min-max) has d beta / d|H| = F(beta, u) on the way out and on the way back
   (u the ray's direction): it retraces its gimbal path and ends where it started, on the
   start's non-singular zero-momentum family. (3) is a rate per second, not per unit of
   momentum, and a saturated rate limit scales the demand: either breaks the retrace, and the
   path then ends somewhere else on the zero-momentum set, which for the rhombus contains the
   two-dimensional singular family beta_1 = beta_3, beta_2 = beta_4 (two pairs cancelling,
   least_squares.py). The barrier sees m fall only in the slew's last seconds, where H' is
   largest and the null motion it needs exceeds the rate limit (docs/theory/steering.md "Steering study").

5. Preference. With beta^0 the gimbal angles the run started from (`preferred_gimbal_angles`),
   v^0 the null vector of J(beta^0) (`preferred_jacobian`; moving along it keeps H = H(beta^0)
   to first order, and for the rhombus the zero-momentum family through (45, -45, -45, 45) deg
   is exactly the line beta^0 + s (1, -1, -1, 1)), the law descends

       P(beta) = sum_i (1 - cos(beta_i - beta^0_i)),   p = grad P = sin(beta - beta^0),
       p_perp = p - (p . v^0) v^0,                        t_p = -k p_perp . v_4            (4)

   (`preference_gain_per_s` = k): t_p is the null coordinate of the motion -k p_perp, the pull
   towards the start's family without a pull along it. P uses 1 - cos so that the pull is smooth
   and periodic in each angle. It is off when the start is itself within m_floor of a singular
   set (there is then nothing to return to) and when k = 0.

6. Budget. Min-max minimises the run's peak rate; a step's rate below the peak the run has
   already commanded (`peak_rate_so_far`) costs nothing in that objective. The preference may
   raise the step's peak rate f(t) = max_i |x_i + t v_4i| up to

       L = max(f(t*), min(peak_rate_so_far, beta'max), nu beta'max),   B = {t : f(t) <= L}      (5)

   (`preference_rate_fraction` = nu: some null motion at rest, where f(t*) = 0). f is convex (a
   maximum of |affine|), so B is an interval that contains the min-max minimiser t* (closed
   form, minimax_exact). Where the demand sets the run's peak (f(t*) >= the peak so far, e.g.
   the first steps of a slew) B = {t*}: the law is min-max there.

7. The command. The wanted coordinate is tau = clip(t* + t_p, B) (tau = t* without a
   preference); the barrier and the bounds come first:

       T and A meet:          t = clip(tau, T n A)        exact torque
       T and A do not meet:   t = the end of T nearest A   the largest dm/dt the bounds allow,
                                                           exact torque, status avoidance_limited
       T empty:               no exact command within the bounds: the largest fraction k of the
                              demand that has one, from the LP  max k  s.t.  lo <= k x + t v_4 <= hi,
                              0 <= k <= 1  (scipy HiGHS; its t is then the min-max one at that k),
                              status rate_limited, scale k. The direction of H' is kept. Only when
                              not even k = 0 fits (an acceleration limit keeps a gimbal turning
                              and v_4 cannot absorb it) are the min-max rates limited like every
                              law's (rate_limit.apply_rate_bounds).

   Neither the avoidance nor the preference ever costs torque: both only move along v_4. Without
   a preference and far from singular sets (A contains t*) the command is exactly the min-max one.

Rank J < 3 (s_3 <= rcond s_1): the null space has dimension >= 2 and m is not differentiable
there; the law then does what `minimax` does (least-squares projection, null-space LP) and
says rank_deficient. docs/theory/steering.md "Steering study" gives how often the law still comes within 1e-3 of
a singular set on random slews, and what the preference costs in peak rate.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from testbed.errors import InputError
from testbed.math.validation import number_in, positive_number
from testbed.steering.least_squares import DEFAULT_RCOND, jacobian_svd, min_norm_solution
from testbed.steering.minimax_exact import minimax_line_parameter
from testbed.steering.minimax_lp import HIGHS_OPTIONS, nullspace_lp_rates
from testbed.steering.result import SteeringResult, limited_result, status_string
from testbed.steering.validation import checked_problem, checked_rate_bounds

# Null-vector components below this fraction of the largest are exactly zero (as minimax_exact).
ZERO_SLOPE = 1e-13


def measure_gradient(svd, column_derivative: np.ndarray) -> np.ndarray:
    """dm/dbeta (4,) of m = sqrt(det(J J^T)), eq. (2), from J's full-rank SVD and dJ_i/dbeta_i (3, 4)."""
    others = svd.measure / svd.s  # m / s_k: product of the other two singular values
    return np.einsum("k,ki,ki->i", others, svd.u.T @ column_derivative, svd.vt)


def line_interval(x: np.ndarray, n: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[float, float]:
    """[t_lo, t_hi] of the t with lo <= x + t n <= hi componentwise (t_lo > t_hi: none)."""
    t_lo, t_hi = -math.inf, math.inf
    floor = ZERO_SLOPE * float(np.max(np.abs(n)))
    for xi, ni, a, b in zip(x, n, lo, hi):
        if abs(ni) <= floor:
            if not a <= xi <= b:
                return math.inf, -math.inf
            continue
        p, q = (a - xi) / ni, (b - xi) / ni
        t_lo, t_hi = max(t_lo, min(p, q)), min(t_hi, max(p, q))
    return t_lo, t_hi


def largest_exact_fraction(x: np.ndarray, n: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[float, float] | None:
    """(k, t) with the largest k in [0, 1] such that lo <= k x + t n <= hi, t the min-max one at
    that k; None when no k in [0, 1] has such a t (the LP in (k, t) of the module doc, step 4)."""
    a_ub = np.vstack([np.column_stack([x, n]), -np.column_stack([x, n])])
    from scipy.optimize import linprog  # on use: at the top it would cost every command start-up time
    res = linprog([-1.0, 0.0], A_ub=a_ub, b_ub=np.r_[hi, -lo], bounds=[(0.0, 1.0), (None, None)],
                  method="highs", options=HIGHS_OPTIONS)
    if res.status != 0:
        return None
    k = float(res.x[0]) + 0.0  # -0.0 reads as 0
    t_lo, t_hi = line_interval(k * x, n, lo, hi)
    t = float(res.x[1])
    if t_lo <= t_hi:  # the LP's t is one feasible point; the interval is usually that point
        t = min(max(minimax_line_parameter((k * x).tolist(), n.tolist()), t_lo), t_hi)
    return k, t


def barrier_choice(t_star: float, t_lo: float, t_hi: float, slope: float, offset: float) -> tuple[float, bool]:
    """(t, met): the t of [t_lo, t_hi] with slope t >= offset (eq. 3 in t) nearest t_star (the
    minimiser over that set of a convex f minimised at t_star; module doc step 7 with t_star = tau);
    when no t of the interval meets it, the end that comes closest (met = False). An all-but-zero
    slope leaves only the check of 0 >= offset."""
    if slope > 0.0:
        t_lo_a, t_hi_a = max(t_lo, offset / slope), t_hi
    elif slope < 0.0:
        t_lo_a, t_hi_a = t_lo, min(t_hi, offset / slope)
    else:
        return min(max(t_star, t_lo), t_hi), offset <= 0.0
    if t_lo_a <= t_hi_a:
        return min(max(t_star, t_lo_a), t_hi_a), True
    return (t_hi if slope > 0.0 else t_lo), False


def preference_null_rate(beta, preferred, null_vector, n: np.ndarray, gain: float) -> float:
    """t_p of eq. (4): the null coordinate of -k p_perp, p = sin(beta - beta0) with its component
    along the start's null vector v0 removed, on the present null vector n."""
    p = np.sin(np.asarray(beta, dtype=float) - preferred)
    return -gain * float((p - (p @ null_vector) * null_vector) @ n)


def budget_interval(x: np.ndarray, n: np.ndarray, t_star: float, level: float) -> tuple[float, float]:
    """B of eq. (5): the t with max_i |x_i + t n_i| <= max(level, f(t*)) (an interval containing t*)."""
    level = max(level, float(np.max(np.abs(x + t_star * n))))
    return line_interval(x, n, np.full(x.shape, -level), np.full(x.shape, level))


def checked_preference(gimbal_angle, preferred_gimbal_angles, preferred_jacobian, floor: float, rcond: float):
    """(beta, beta0, v0) of eq. (4) from the step inputs, or None when there is no preference: an
    input missing, or the start within m_floor of a singular set."""
    if gimbal_angle is None or preferred_gimbal_angles is None or preferred_jacobian is None:
        return None
    try:
        beta, start, jacobian = (np.asarray(v, dtype=float) for v in (gimbal_angle, preferred_gimbal_angles,
                                                                        preferred_jacobian))
    except (TypeError, ValueError):
        raise InputError("steering.preferred_gimbal_angles", "gimbal_angle, preferred_gimbal_angles and "
                         "preferred_jacobian must be numbers") from None
    if beta.shape != (4,) or start.shape != (4,) or jacobian.shape != (3, 4) or not (
            np.all(np.isfinite(beta)) and np.all(np.isfinite(start)) and np.all(np.isfinite(jacobian))):
        raise InputError("steering.preferred_gimbal_angles", "gimbal_angle and preferred_gimbal_angles must be "
                         "4 finite angles and preferred_jacobian a finite 3x4 matrix")
    rank, measure, null_vector = _start_null_vector(jacobian.tobytes(), rcond)
    if rank < 3 or measure <= floor:
        return None
    return beta, start, null_vector


@functools.lru_cache(maxsize=16)
def _start_null_vector(jacobian: bytes, rcond: float) -> tuple[int, float, np.ndarray]:
    """(rank, measure, v0) of the start's J (3x4, as bytes): the same J comes at every step of a
    run, so its SVD is taken once (it was a fifth of a step's cost). v0 is read-only."""
    svd = jacobian_svd(np.frombuffer(jacobian).reshape(3, 4), rcond)
    null_vector = svd.null_space[0].copy()
    null_vector.flags.writeable = False
    return svd.rank, svd.measure, null_vector


def minimax_avoid_steering(J, h, Hdot, beta_rate_max, *, column_derivative=None, measure_floor: float = 0.3,
                           barrier_gain_per_s: float = 0.5, preference_gain_per_s: float = 1.0,
                           preference_rate_fraction: float = 0.1, gimbal_angle=None, preferred_gimbal_angles=None,
                           preferred_jacobian=None, peak_rate_so_far: float = 0.0, rate_bounds=None,
                           rcond: float = DEFAULT_RCOND) -> SteeringResult:
    """Min-max gimbal rates under the singularity barrier with the pull back to the start's
    zero-momentum family (module doc, eq. 1-5), within the bounds.

    column_derivative: (3, 4), column i = dJ_i/dbeta_i at the same gimbal angles as J (required).
    gimbal_angle, preferred_gimbal_angles: (4,) [rad], the angles J is taken at and those the run
    started from; preferred_jacobian: J at the latter (3, 4). Without all three: no preference.
    peak_rate_so_far: the largest |beta'_i| the run has commanded [rad/s] (eq. 5).
    rate_bounds: optional (lo, hi), each (4,) [rad/s], intersected with +-beta_rate_max.
    """
    rows, h, hdot, beta_rate_max = checked_problem(J, h, Hdot, beta_rate_max)
    if column_derivative is None:
        raise InputError("steering.column_derivative", "minimax_avoid needs dJ_i/dbeta_i (3x4) at the same "
                         "gimbal angles as J")
    try:
        derivative = np.asarray(column_derivative, dtype=float)
    except (TypeError, ValueError):
        derivative = np.empty(0)
    if derivative.shape != (3, 4) or not np.all(np.isfinite(derivative)):
        raise InputError("steering.column_derivative", "must be a 3x4 matrix of finite numbers")
    floor = number_in("steering.measure_floor", measure_floor, 0.0, math.inf, high_open=True)
    gain = positive_number("steering.barrier_gain_per_s", barrier_gain_per_s)
    rcond = number_in("steering.rcond", rcond, 0.0, 1.0, low_open=True, high_open=True)
    preference_gain = number_in("steering.preference_gain_per_s", preference_gain_per_s, 0.0, math.inf,
                                high_open=True)
    rate_fraction = number_in("steering.preference_rate_fraction", preference_rate_fraction, 0.0, 1.0)
    peak_so_far = number_in("steering.peak_rate_so_far", peak_rate_so_far, 0.0, math.inf, high_open=True)
    preference = checked_preference(gimbal_angle, preferred_gimbal_angles, preferred_jacobian, floor, rcond)
    lo, hi = checked_rate_bounds(rate_bounds, beta_rate_max, len(rows[0]))
    J = np.array(rows)
    b = np.array(hdot) / h
    svd = jacobian_svd(J, rcond)
    if svd.rank < 3:  # least squares, as minimax: the min-max rates for the reachable part of b
        p = min_norm_solution(svd, b)
        lp = nullspace_lp_rates(p, svd.null_space)
        return limited_result(J, h, p if lp is None else lp, beta_rate_max, svd.measure, svd.rank,
                              lp is None, bounds=(lo, hi))
    x, n = min_norm_solution(svd, b), svd.null_space[0]
    t_star = minimax_line_parameter(x.tolist(), n.tolist())
    t_lo, t_hi = line_interval(x, n, lo, hi)
    if t_lo > t_hi:  # no exact-torque command within the bounds: the largest fraction of H' that has one
        fraction = largest_exact_fraction(x, n, lo, hi)
        if fraction is None:
            return limited_result(J, h, x + t_star * n, beta_rate_max, svd.measure, svd.rank, bounds=(lo, hi))
        k, t = fraction
        beta_rate = np.clip(k * x + t * n, lo, hi)
        return SteeringResult(beta_rate, h * (J @ beta_rate), k, svd.measure, svd.rank, status_string(True))
    g = measure_gradient(svd, derivative)
    offset = -gain * (svd.measure - floor) - float(g @ x)
    slope = float(g @ n)
    if abs(slope) <= ZERO_SLOPE * float(np.linalg.norm(g)):
        slope = 0.0
    target = t_star
    if preference is not None and preference_gain > 0.0:
        level = max(min(peak_so_far, beta_rate_max), rate_fraction * beta_rate_max)
        band_lo, band_hi = budget_interval(x, n, t_star, level)
        target = min(max(t_star + preference_null_rate(*preference, n, preference_gain), band_lo), band_hi)
    t, met = barrier_choice(target, t_lo, t_hi, slope, offset)
    beta_rate = np.clip(x + t * n, lo, hi)  # the clip only removes rounding at an end of T
    return SteeringResult(beta_rate, h * (J @ beta_rate), 1.0, svd.measure, svd.rank,
                          status_string(False, avoidance_limited=not met))
