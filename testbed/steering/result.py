"""The one result type every steering law returns."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.steering.rate_limit import (apply_rate_bounds, apply_rate_bounds_rows, apply_rate_limit,
                                         apply_rate_limit_rows)

# Status flags (joined with "+" when several apply).
OK = "ok"
RATE_LIMITED = "rate_limited"        # demand scaled by `scale` < 1 to respect beta_rate_max
RANK_DEFICIENT = "rank_deficient"    # rank J < 3: pinv/min-max project the demand onto
                                     # range(J) first; SR/GSR damp instead
LP_FAILED = "lp_failed"              # HiGHS gave no optimum; min-norm rates were used instead
AVOIDANCE_LIMITED = "avoidance_limited"  # minimax_avoid: the singularity barrier asked for more
                                         # null motion than the rate bounds allow (torque still exact)

# The flags as bits of one number, so the trace (numbers only) can hold the status:
# `allocator/status` = the sum of the codes of the flags that apply (0: ok).
STATUS_CODES = {RATE_LIMITED: 1, RANK_DEFICIENT: 2, LP_FAILED: 4, AVOIDANCE_LIMITED: 8}


@dataclass(slots=True)
class SteeringResult:
    """Gimbal-rate command of one steering law for one demand.

    beta_rate            (4,) commanded gimbal rates [rad/s], |beta_rate_i| <= beta_rate_max
    hdot_delivered       (3,) momentum rate those rates produce, h J beta_rate [N m]
    scale                factor k in (0, 1] applied to the demand by the rate limit (1: none)
    singularity_measure  m = sqrt(det(J J^T)) of the unit-h Jacobian (0 at a singularity)
    rank                 numerical rank of J used by the law (3 unless singular)
    status               "ok" or "+"-joined flags: rate_limited, rank_deficient, lp_failed,
                         avoidance_limited
    """

    beta_rate: np.ndarray
    hdot_delivered: np.ndarray
    scale: float
    singularity_measure: float
    rank: int
    status: str


@dataclass(slots=True)
class SteeringRows:
    """`SteeringResult`s of N worlds, a row each: beta_rate (N, n) [rad/s], hdot_delivered (N, 3)
    [N m], scale (N,), singularity_measure (N,), rank (N,) and status (N,) as the sum of its
    flags' STATUS_CODES (the number the trace records)."""

    beta_rate: np.ndarray
    hdot_delivered: np.ndarray
    scale: np.ndarray
    singularity_measure: np.ndarray
    rank: np.ndarray
    status: np.ndarray


def status_string(rate_limited: bool, rank_deficient: bool = False, lp_failed: bool = False,
                  avoidance_limited: bool = False) -> str:
    """Join the flags that apply into the status string ("ok" when none do)."""
    flags = [name for name, on in ((RANK_DEFICIENT, rank_deficient), (LP_FAILED, lp_failed),
                                   (AVOIDANCE_LIMITED, avoidance_limited), (RATE_LIMITED, rate_limited)) if on]
    return "+".join(flags) if flags else OK


def status_code(status: str) -> int:
    """The status string as the sum of its flags' STATUS_CODES (0 for "ok")."""
    return sum(STATUS_CODES[flag] for flag in status.split("+") if flag != OK)


def limited_result(J, h, beta_rate, beta_rate_max, measure, rank, lp_failed=False, bounds=None) -> SteeringResult:
    """Rate-limit beta_rate (eq. 4) and pack it with the momentum rate it delivers, h J beta'.

    bounds: optional (lo, hi) per-gimbal rate bounds (4,) already within +-beta_rate_max
    (validation.checked_rate_bounds); then they replace the symmetric limit (apply_rate_bounds).
    """
    if bounds is None:
        beta_rate, k = apply_rate_limit(beta_rate, beta_rate_max)
    else:
        beta_rate, k = apply_rate_bounds(beta_rate, *bounds)
    return SteeringResult(beta_rate, h * (J @ beta_rate), k, measure, rank,
                          status_string(k < 1.0, rank < 3, lp_failed))


def limited_rows(J, h, beta_rate, beta_rate_max, measure, rank, bounds=None) -> SteeringRows:
    """`limited_result` on N worlds' rows: J (N, 3, n), h (N,) [N m s], beta_rate (N, n) [rad/s],
    beta_rate_max (N,) [rad/s], measure and rank (N,); bounds: optional (lo, hi) (N, n) each,
    within +-beta_rate_max (they replace the symmetric limit, as in `limited_result`)."""
    if bounds is None:
        beta_rate, k = apply_rate_limit_rows(beta_rate, beta_rate_max)
    else:
        beta_rate, k = apply_rate_bounds_rows(beta_rate, *bounds)
    # h J b' summed over the units left to right, as the single min-max law sums it (a stacked
    # matmul may add in another order and move a world's torque by an ulp)
    terms = J * beta_rate[:, None, :]
    total = terms[..., 0]
    for unit in range(1, terms.shape[-1]):
        total = total + terms[..., unit]
    delivered = h[:, None] * total
    status = STATUS_CODES[RATE_LIMITED] * (k < 1.0) + STATUS_CODES[RANK_DEFICIENT] * (rank < 3)
    return SteeringRows(beta_rate, delivered, k, measure, rank, status)
