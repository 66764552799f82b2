"""Min-max steering as a linear program (SEEDS §004 eq. (21)-(28)), solved by HiGHS.

Problem (21): minimise max_i |beta'_i| subject to J beta' = b (eq. 17, b = H'/h).

Two exact LP forms are offered; tests check they give the same optimum:

- form="paper" (default, rank 3): the paper's reduction (22)-(27). One rate beta'_n = Z1 is
  kept free and the other three follow from (22): beta'_rest = Y^-1 (b - P Z1) = c0 + c1 Z1
  (23), Y = J without column n, P = column n. Then minimise Z2 subject to Z2 >= +-Z1,
  Z2 >= +-(c_i0 + c_i1 Z1) (27). The OCR of (25) calls Z2 the vector (beta'_2..4); in
  (26)-(28) Z2 is the scalar bound on all |beta'_i|, which is what is solved here. The paper
  takes n = 1 and asks rank Y = 3; here n is the column whose removal leaves the largest
  |det Y| (best conditioned Y). J beta' = b holds by construction, to the accuracy of the
  3x3 solve: that is why it is the default.
- form="epigraph": variables (beta'_1..4, s), minimise s subject to J beta' = b and
  -s <= beta'_i <= s. Needs no pivot, so it also serves rank-deficient J; but J beta' = b only
  holds to HiGHS's absolute feasibility tolerance, which within 1e-8 of a singular set (rates
  ~1e7 before the rate limit) left the delivered direction off by percents in tests.

The paper's bound (28), Z2 <= beta'max, is not put into the LP: an unreachable demand would
make the LP infeasible and give no command at all. The rate limit scales the demand instead,
which is exact because the min-max optimum is positively homogeneous in b (rate_limit.py).
Rank J < 3 (SVD, relative tolerance rcond): max|beta'_i| is minimised over the least-squares
solutions, i.e. for the projection of b onto range(J). The paper form then becomes an LP in
the (4 - rank) null-space coordinates plus the bound (nullspace_lp_rates); the epigraph form
uses the projected b.
"""

from __future__ import annotations

import numpy as np

from testbed.errors import InputError
from testbed.steering.least_squares import (DEFAULT_RCOND, jacobian_svd, min_norm_solution,
                                            project_onto_range)
from testbed.steering.result import SteeringResult, limited_result
from testbed.math.validation import number_in
from testbed.steering.validation import checked_problem, checked_rate_bounds

LP_FORMS = ("epigraph", "paper")
# Tight HiGHS tolerances: the answer is a simplex vertex, exact up to rounding once optimal.
HIGHS_OPTIONS = {"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10}


def epigraph_lp_rates(J: np.ndarray, b: np.ndarray) -> np.ndarray | None:
    """argmin max|beta'_i| s.t. J beta' = b (J: 3 x n), via the LP in (beta', s); None if HiGHS
    fails. b must lie in range(J) (always true at rank 3; project it first otherwise).
    """
    units = J.shape[1]
    I = np.eye(units)
    a_ub = np.block([[I, -np.ones((units, 1))], [-I, -np.ones((units, 1))]])  # +-beta'_i - s <= 0
    a_eq = np.hstack([J, np.zeros((3, 1))])
    bounds = [(None, None)] * units + [(0, None)]
    from scipy.optimize import linprog  # on use: at the top it would cost every command start-up time
    res = linprog(np.r_[np.zeros(units), 1.0], A_ub=a_ub, b_ub=np.zeros(2 * units), A_eq=a_eq, b_eq=b,
                  bounds=bounds, method="highs", options=HIGHS_OPTIONS)
    return res.x[:units] if res.status == 0 else None


def paper_lp_rates(J: np.ndarray, b: np.ndarray) -> np.ndarray | None:
    """argmin max|beta'_i| s.t. J beta' = b via the paper's 2-variable LP (22)-(27), rank 3 only.

    Returns None if HiGHS fails.
    """
    minors = [abs(np.linalg.det(np.delete(J, n, axis=1))) for n in range(4)]
    n = int(np.argmax(minors))
    rest = [i for i in range(4) if i != n]
    Y, P = J[:, rest], J[:, n]
    c0 = np.linalg.solve(Y, b)    # (22)-(23): beta'_rest = c0 + c1 * Z1
    c1 = -np.linalg.solve(Y, P)
    # Rows of (27) as a_z1 * Z1 - Z2 <= rhs: Z2 >= +-Z1 and Z2 >= +-(c_i0 + c_i1 Z1).
    a_ub = np.column_stack([np.r_[1.0, -1.0, c1, -c1], -np.ones(8)])
    b_ub = np.r_[0.0, 0.0, -c0, c0]
    from scipy.optimize import linprog
    res = linprog([0.0, 1.0], A_ub=a_ub, b_ub=b_ub, bounds=[(None, None), (0, None)],
                  method="highs", options=HIGHS_OPTIONS)
    if res.status != 0:
        return None
    z1 = res.x[0]
    beta_rate = np.empty(4)
    beta_rate[n] = z1
    beta_rate[rest] = c0 + c1 * z1
    return beta_rate


def nullspace_lp_rates(p: np.ndarray, null_rows: np.ndarray) -> np.ndarray | None:
    """argmin max|beta'_i| over beta' = p + N^T z, via the LP in (z, s); None if HiGHS fails.

    The paper's reduction (22)-(27) generalised to any null-space dimension d = n - rank for n
    units: the solution set of J beta' = b is parametrised exactly (p: minimum-norm solution,
    rows of null_rows: an orthonormal basis of ker J), so the LP only chooses z and J beta' = b
    holds to rounding. Used where d != 1 (rank J < 3, or n > 4 units), where the 1-D paper form
    does not apply; d = 0 (3 units at rank 3) leaves p itself.
    """
    d, units = null_rows.shape[0], len(p)
    if d == 0:
        return p
    N = null_rows.T  # (n, d)
    a_ub = np.block([[N, -np.ones((units, 1))], [-N, -np.ones((units, 1))]])  # +-(p + N z) <= s
    from scipy.optimize import linprog
    res = linprog(np.r_[np.zeros(d), 1.0], A_ub=a_ub, b_ub=np.r_[-p, p],
                  bounds=[(None, None)] * d + [(0, None)], method="highs", options=HIGHS_OPTIONS)
    return p + N @ res.x[:d] if res.status == 0 else None


def minimax_lp_steering(J, h, Hdot, beta_rate_max, *, form: str = "paper",
                        rcond: float = DEFAULT_RCOND, rate_bounds=None) -> SteeringResult:
    """Min-max gimbal rates (eq. 21) from scipy's HiGHS LP, rate-limited (eq. 4, 28), for a
    cluster of n units (J: 3 x n); the paper form is the 4-unit one, other n take the null-space LP.

    Rank J < 3 (SVD, tolerance rcond): minimises max|beta'_i| among the least-squares
    solutions, i.e. for the projection of H' onto range(J) (nullspace_lp_rates). If HiGHS reports no optimum
    (not seen in tests) the minimum-norm rates are used and the status says lp_failed.
    rate_bounds: optional per-gimbal (lo, hi) (rate_limit.apply_rate_bounds).
    """
    rows, h, hdot, beta_rate_max = checked_problem(J, h, Hdot, beta_rate_max)
    if form not in LP_FORMS:
        raise InputError("steering.form", f"must be one of {', '.join(LP_FORMS)}")
    rcond = number_in("steering.rcond", rcond, 0.0, 1.0, low_open=True, high_open=True)
    bounds = None if rate_bounds is None else checked_rate_bounds(rate_bounds, beta_rate_max, len(rows[0]))
    J = np.array(rows)
    b = np.array(hdot) / h
    svd = jacobian_svd(J, rcond)
    if form == "epigraph":
        beta_rate = epigraph_lp_rates(J, b if svd.rank == 3 else project_onto_range(svd, b))
    elif svd.rank == 3 and J.shape[1] == 4:
        beta_rate = paper_lp_rates(J, b)
    else:  # least-squares solutions p + N z; p = min-norm solution of the projected demand
        beta_rate = nullspace_lp_rates(min_norm_solution(svd, b), svd.null_space)
    failed = beta_rate is None
    if failed:
        beta_rate = min_norm_solution(svd, b)
    return limited_result(J, h, beta_rate, beta_rate_max, svd.measure, svd.rank, failed, bounds=bounds)
