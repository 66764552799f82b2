"""Exact closed-form min-max steering for a 4-gimbal cluster (SEEDS §004 eq. (21)-(27)); a
cluster of n != 4 units takes the closed form of the LP's dual (minimax_dual.py).

A 3x4 J of rank 3 has a one-dimensional null space n, so every solution of J beta' = b is
beta' = x + t n (t real), and the min-max objective f(t) = max_i |x_i + t n_i| is convex and
piecewise linear in the scalar t. This is the paper's reduction (23)-(24) (there t = beta'_1)
solved without an LP: write each |x_i + t n_i| as w_i |t - r_i| with w_i = |n_i|; the increasing
line of pair i and the decreasing line of pair j cross at value

    v_ij = (w_j s_i x_i - w_i s_j x_j) / (w_i + w_j),  s_i = sign(n_i),

at t_ij = -(s_i x_i + s_j x_j) / (w_i + w_j). Every v_ij is a lower bound of f (one line rises,
the other falls), and at the minimiser the rising and falling envelopes meet at such a
crossing, so min f = max_ij v_ij, reached at the t_ij of the maximising pair (12 pairs).
Lines with n_i = 0 are constants |x_i|; they are left out of the pairs and cannot change the
minimiser, only the value, which is read off the final beta' anyway.

The null vector is the signed 3x3 minors n_i = (-1)^i det(J without column i) (Laplace
expansion of a 4x4 with a repeated row gives J n = 0), and |n| = sqrt(det(J J^T)) by
Cauchy-Binet, so the singularity measure comes free. A particular solution x has x_k = 0 for
the k with the largest minor and the other three from Y^-1 b (adjugate of Y, eq. 22). All of it is done on
Python floats: for 4 unknowns that is several times faster than numpy's per-call overhead.

Where minors lose relative accuracy (|n| <= 1e-4 |J|_F^3) the null vector and minimum-norm
solution come from the SVD instead; at rank J < 3 (SVD, tolerance rcond) the null space has
dimension >= 2 and the LP over it (minimax_lp.nullspace_lp_rates) is solved for the
least-squares projection of b onto range(J): rare, so its ~1 ms does not matter.
"""

from __future__ import annotations

import math

import numpy as np

from testbed.errors import InputError
from testbed.steering.least_squares import DEFAULT_RCOND, jacobian_svd, min_norm_solution
from testbed.steering.minimax_dual import dual_minimax_rates
from testbed.steering.minimax_lp import nullspace_lp_rates
from testbed.steering.result import (SteeringResult, SteeringRows, limited_result, limited_rows, status_code,
                                     status_string)
from testbed.math.validation import number_in
from testbed.steering.validation import checked_problem, checked_rate_bounds

# Below |n| = NEAR_SINGULAR * |J|_F^3 the cofactor formulas lose > ~1e-12 relative accuracy.
NEAR_SINGULAR = 1e-4
# Null-vector components below this fraction of the largest are treated as exactly zero.
ZERO_SLOPE = 1e-13
_PAIRS = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))


def minimize_max_abs_on_line(x, n, price: float = 0.0) -> list[float]:
    """argmin over beta = x + t n of max_i |beta_i| (4 floats each, n != 0), in closed form;
    with a price > 0, of max_i |beta_i| + price |beta - beta_min-norm| (priced_line_parameter)."""
    t = minimax_line_parameter(x, n) if price == 0.0 else priced_line_parameter(x, n, price)
    return [x[0] + t * n[0], x[1] + t * n[1], x[2] + t * n[2], x[3] + t * n[3]]


def minimax_line_parameter(x, n) -> float:
    """The t minimising max_i |x_i + t n_i| (4 floats each, n != 0), in closed form.

    v_ji = -v_ij and t_ij = t_ji, so the 12 ordered crossings reduce to the 6 pairs' |v_ij|.
    """
    w = [abs(n[0]), abs(n[1]), abs(n[2]), abs(n[3])]
    a = [xi if ni >= 0.0 else -xi for xi, ni in zip(x, n)]  # s_i x_i
    k = w.index(max(w))
    floor = ZERO_SLOPE * w[k]
    best_v, best_t = -1.0, -a[k] / w[k]  # the root of line k alone, if it has no partner
    for i, j in _PAIRS:
        wi, wj = w[i], w[j]
        if wi > floor and wj > floor:
            v, t = pair_crossing(wi, wj, a[i], a[j])
            if v > best_v:
                best_v, best_t = v, t
    return best_t


def pair_crossing(wi, wj, ai, aj):
    """(v_ij, t_ij) of the module doc: where the rising line of one gimbal of a pair meets the
    falling line of the other (w: |n|, a: sign(n) x); floats, or arrays elementwise."""
    den = wi + wj
    return abs(wj * ai - wi * aj) / den, -(ai + aj) / den


def priced_line_parameter(x, n, price: float) -> float:
    """The t minimising max_i |x_i + t n_i| + price |n| |t - t0| (4 floats each, n != 0), where
    t0 = -(x . n) / |n|^2 is the minimum-norm solution, so the second term is price times the
    null motion's size |beta' - beta'_min-norm| (docs/theory/steering.md, "A price on null motion").

    The function is convex and piecewise linear in t, so its minimum lies at a kink: a root
    -x_i / n_i, a crossing of two lines +-(x_i + t n_i), or t0; those between the min-max t and
    t0 (the two terms' minimisers) are compared. The exact
    min-max t is kept wherever the envelope rises faster than price |n| on both of its sides.
    """
    norm2 = n[0] * n[0] + n[1] * n[1] + n[2] * n[2] + n[3] * n[3]
    t0 = -(x[0] * n[0] + x[1] * n[1] + x[2] * n[2] + x[3] * n[3]) / norm2
    weight = price * math.sqrt(norm2)
    exact = minimax_line_parameter(x, n)
    # both terms are convex, so the minimum lies between their minimisers: kinks outside are skipped
    low, high = min(exact, t0), max(exact, t0)
    candidates = [t0, exact] + [-xi / ni for xi, ni in zip(x, n) if ni != 0.0 and low < -xi / ni < high]
    for i, j in _PAIRS:
        for sign in (1.0, -1.0):
            den = n[i] - sign * n[j]
            if den != 0.0 and low < -(x[i] - sign * x[j]) / den < high:
                candidates.append(-(x[i] - sign * x[j]) / den)
    best_t, best_f = t0, math.inf
    for t in candidates:
        f = max(abs(x[0] + t * n[0]), abs(x[1] + t * n[1]), abs(x[2] + t * n[2]),
                abs(x[3] + t * n[3])) + weight * abs(t - t0)
        if f < best_f:
            best_t, best_f = t, f
    return best_t


def cofactor_null_vector(rows) -> list[float]:
    """n_i = (-1)^i det(J without column i): J n = 0 and |n|^2 = det(J J^T) (Cauchy-Binet)."""
    r0, r1, r2 = rows
    # 2x2 minors of rows 1-2 for column pairs (i, j), shared by the four 3x3 expansions.
    m01, m02, m03 = r1[0] * r2[1] - r1[1] * r2[0], r1[0] * r2[2] - r1[2] * r2[0], r1[0] * r2[3] - r1[3] * r2[0]
    m12, m13, m23 = r1[1] * r2[2] - r1[2] * r2[1], r1[1] * r2[3] - r1[3] * r2[1], r1[2] * r2[3] - r1[3] * r2[2]
    return [r0[1] * m23 - r0[2] * m13 + r0[3] * m12, -(r0[0] * m23 - r0[2] * m03 + r0[3] * m02),
            r0[0] * m13 - r0[1] * m03 + r0[3] * m01, -(r0[0] * m12 - r0[1] * m02 + r0[2] * m01)]


def particular_solution(rows, b, n) -> list[float]:
    """x with J x = b and x_k = 0, k = argmax |n_k| (eq. 22 with the best conditioned Y).

    Y = J without column k has |det Y| = |n_k| > 0; Y^-1 = [y1 x y2, y2 x y0, y0 x y1]^T / det Y.
    """
    abs_n = [abs(v) for v in n]
    k = abs_n.index(max(abs_n))
    cols = [i for i in (0, 1, 2, 3) if i != k]
    x = [0.0, 0.0, 0.0, 0.0]
    for i, value in zip(cols, adjugate_solution(*([rows[0][i], rows[1][i], rows[2][i]] for i in cols), b)):
        x[i] = value
    return x


def adjugate_solution(y0, y1, y2, b) -> tuple:
    """Y^-1 b for Y = [y0 y1 y2] (columns, 3 each): [y1 x y2, y2 x y0, y0 x y1]^T b / det Y (eq. 22);
    floats, or arrays elementwise (a row per world)."""
    c12 = (y1[1] * y2[2] - y1[2] * y2[1], y1[2] * y2[0] - y1[0] * y2[2], y1[0] * y2[1] - y1[1] * y2[0])
    c20 = (y2[1] * y0[2] - y2[2] * y0[1], y2[2] * y0[0] - y2[0] * y0[2], y2[0] * y0[1] - y2[1] * y0[0])
    c01 = (y0[1] * y1[2] - y0[2] * y1[1], y0[2] * y1[0] - y0[0] * y1[2], y0[0] * y1[1] - y0[1] * y1[0])
    inv_det = 1.0 / (y0[0] * c12[0] + y0[1] * c12[1] + y0[2] * c12[2])
    return tuple((b[0] * cross[0] + b[1] * cross[1] + b[2] * cross[2]) * inv_det for cross in (c12, c20, c01))


def minimax_steering(J, h, Hdot, beta_rate_max, *, rcond: float = DEFAULT_RCOND, null_motion_price: float = 0.0,
                     rate_bounds=None) -> SteeringResult:
    """Min-max gimbal rates (eq. 21 subject to 17), exactly and in microseconds, rate-limited.

    Same optimum as minimax_lp_steering (tested to 1e-9 relative); the rate limit scales the
    demand by k = beta_rate_max / min-max value, exact since the optimum is linear in H'.
    null_motion_price: p >= 0; the rates minimise max_i |b'_i| + p |b' - b'_min-norm| instead
    (priced_line_parameter): null motion is taken only where it lowers the peak rate by more than
    p per unit of its own size, which keeps the optimum continuous where the min-max's is not
    (a saturated gimbal with a nearly zero null component). 0: the paper's min-max.
    rate_bounds: optional per-gimbal (lo, hi), applied to the min-max rates like every law's
    (rate_limit.apply_rate_bounds; minimax_avoid uses the null space to meet them instead).
    """
    rows, h, hdot, beta_rate_max = checked_problem(J, h, Hdot, beta_rate_max)
    if rcond != DEFAULT_RCOND:  # skip the check on the hot path's default
        rcond = number_in("steering.rcond", rcond, 0.0, 1.0, low_open=True, high_open=True)
    if null_motion_price != 0.0:
        null_motion_price = number_in("steering.null_motion_price", null_motion_price, 0.0, 1.0)
    if len(rows[0]) != 4:
        if null_motion_price != 0.0:
            raise InputError("steering.null_motion_price", f"prices a one-dimensional null space: a 4-unit "
                             f"cluster's, not {len(rows[0])} units'")
        return _other_count(rows, h, hdot, beta_rate_max, rcond, rate_bounds)
    b = (hdot[0] / h, hdot[1] / h, hdot[2] / h)
    n = cofactor_null_vector(rows)
    measure = math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2] + n[3] * n[3])  # Cauchy-Binet
    fro2 = sum(v * v for v in rows[0]) + sum(v * v for v in rows[1]) + sum(v * v for v in rows[2])
    rank, lp_failed = 3, False
    if measure > NEAR_SINGULAR * fro2 * math.sqrt(fro2):
        beta = minimize_max_abs_on_line(particular_solution(rows, b, n), n, null_motion_price)
    else:
        Jm, bv = np.array(rows), np.array(b)
        svd = jacobian_svd(Jm, rcond)
        rank, measure = svd.rank, svd.measure
        if rank == 3:
            beta = minimize_max_abs_on_line(min_norm_solution(svd, bv).tolist(),
                                            svd.null_space[0].tolist(), null_motion_price)
        else:
            p = min_norm_solution(svd, bv)  # least squares: min-norm solution for projected b
            lp = nullspace_lp_rates(p, svd.null_space)
            lp_failed = lp is None
            beta = (p if lp_failed else lp).tolist()
    if rate_bounds is not None:
        bounds = checked_rate_bounds(rate_bounds, beta_rate_max, len(rows[0]))
        return limited_result(np.array(rows), h, np.array(beta), beta_rate_max, measure, rank, lp_failed,
                              bounds=bounds)
    # Rate limit (eq. 4): the min-max optimum scales linearly with the demand.
    peak = max(abs(beta[0]), abs(beta[1]), abs(beta[2]), abs(beta[3]))
    scale = 1.0
    if peak > beta_rate_max:
        scale = beta_rate_max / peak
        beta = [min(max(scale * v, -beta_rate_max), beta_rate_max) for v in beta]
    delivered = [h * (r[0] * beta[0] + r[1] * beta[1] + r[2] * beta[2] + r[3] * beta[3])
                 for r in rows]
    return SteeringResult(np.array(beta), np.array(delivered), scale, measure, rank,
                          status_string(scale < 1.0, rank < 3, lp_failed))


def _other_count(rows, h, hdot, beta_rate_max, rcond, rate_bounds) -> SteeringResult:
    """Min-max on n != 4 units (an (n - 3)-dimensional null space): at rank 3 from the LP's dual in
    closed form (minimax_dual.py), certified; where the certificate fails or rank J < 3, the LP
    over the null space for the least-squares projection of the demand (minimax_lp.py)."""
    J, b = np.array(rows), np.array(hdot) / h
    svd = jacobian_svd(J, rcond)
    beta = dual_minimax_rates(J, b) if svd.rank == 3 else None
    lp_failed = False
    if beta is None:
        p = min_norm_solution(svd, b)
        lp = nullspace_lp_rates(p, svd.null_space)
        lp_failed = lp is None
        beta = p if lp_failed else lp
    bounds = None if rate_bounds is None else checked_rate_bounds(rate_bounds, beta_rate_max, len(rows[0]))
    return limited_result(J, h, beta, beta_rate_max, svd.measure, svd.rank, lp_failed, bounds=bounds)


# --- many worlds at once: the same formulas on a row per world (testbed.batch) -------------------
_OTHER_COLUMNS = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]])
_PAIR_FIRST, _PAIR_SECOND = np.array(_PAIRS).T


def minimax_steering_rows(J, h, hdot, beta_rate_max, *, rcond: float, null_motion_price: float,
                          rate_bounds=None) -> SteeringRows:
    """`minimax_steering` of N worlds' 4-unit problems, a row each: J (N, 3, 4), h (N,) [N m s],
    hdot (N, 3) [N m], beta_rate_max (N,) [rad/s], rate_bounds None or (lo, hi) (N, 4) each; finite
    inputs and the options already checked (the stage checks them once). The closed form runs on
    all rows together, its one branch (the pair of gimbals whose lines cross highest) chosen by
    argmax; a row where the cofactor formulas lose accuracy (|n| <= NEAR_SINGULAR |J|_F^3, the SVD and LP branch) or a priced null
    motion (null_motion_price > 0) takes `minimax_steering` itself. Row i is world i's result to
    the last bit where numpy's elementwise arithmetic is Python's."""
    count = len(J)
    b = hdot / h[:, None]
    rows = np.ascontiguousarray(J.transpose(1, 2, 0))  # (3, 4, N): rows[r][c] a row per world
    n = cofactor_null_vector(rows)
    measure = np.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2] + n[3] * n[3])
    fro2 = sum(v * v for v in rows[0]) + sum(v * v for v in rows[1]) + sum(v * v for v in rows[2])
    closed = measure > NEAR_SINGULAR * fro2 * np.sqrt(fro2)
    null = np.array(n)  # (4, N)
    # particular solution (particular_solution): x_k = 0 at k = argmax |n_k|, the others Y^-1 b
    others = _OTHER_COLUMNS[np.argmax(np.abs(null), axis=0)].T  # (3, N): the kept units
    worlds = np.arange(count)
    Y = rows[:, others, worlds]  # (3, 3, N): Y[r, c] row r of the kept unit c
    solved = adjugate_solution(Y[:, 0], Y[:, 1], Y[:, 2], b.T)
    x = np.zeros((4, count))
    x[others, worlds] = solved
    beta = (x + minimax_line_parameter_rows(x, null) * null).T
    result = limited_rows(J, h, beta, beta_rate_max, measure, np.full(count, 3), rate_bounds)
    for row in np.flatnonzero(~closed if null_motion_price == 0.0 else np.ones(count, bool)).tolist():
        single = minimax_steering(J[row], h[row], hdot[row], beta_rate_max[row], rcond=rcond,
                                  null_motion_price=null_motion_price,
                                  rate_bounds=None if rate_bounds is None else [bound[row] for bound in rate_bounds])
        result.beta_rate[row], result.hdot_delivered[row] = single.beta_rate, single.hdot_delivered
        result.scale[row], result.singularity_measure[row] = single.scale, single.singularity_measure
        result.rank[row], result.status[row] = single.rank, status_code(single.status)
    return result


def minimax_line_parameter_rows(x, n):
    """`minimax_line_parameter` of N lines at once: x, n (4, N) -> t (N,); the 6 pairs' crossings
    (6, N) at once, the highest taken by argmax, which like the single form's scan keeps the first
    pair of a tie (so the same t)."""
    w = np.abs(n)
    a = np.where(n >= 0.0, x, -x)
    k = np.argmax(w, axis=0)
    columns = np.arange(w.shape[1])
    floor = ZERO_SLOPE * w[k, columns]
    wi, wj = w[_PAIR_FIRST], w[_PAIR_SECOND]
    v, t = pair_crossing(wi, wj, a[_PAIR_FIRST], a[_PAIR_SECOND])
    v = np.where((wi > floor) & (wj > floor), v, -1.0)  # a pair with a flat line has no crossing
    best = np.argmax(v, axis=0)
    return np.where(v[best, columns] > -1.0, t[best, columns], -a[k, columns] / w[k, columns])
