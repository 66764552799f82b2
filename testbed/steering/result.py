"""The one result type every steering law returns."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.steering.rate_limit import apply_rate_limit

# Status flags (joined with "+" when several apply).
OK = "ok"
RATE_LIMITED = "rate_limited"        # demand scaled by `scale` < 1 to respect beta_rate_max
RANK_DEFICIENT = "rank_deficient"    # rank J < 3: pinv/min-max project the demand onto
                                     # range(J) first; SR/GSR damp instead
LP_FAILED = "lp_failed"              # HiGHS gave no optimum; min-norm rates were used instead


@dataclass(slots=True)
class SteeringResult:
    """Gimbal-rate command of one steering law for one demand.

    beta_rate            (4,) commanded gimbal rates [rad/s], |beta_rate_i| <= beta_rate_max
    hdot_delivered       (3,) momentum rate those rates produce, h J beta_rate [N m]
    scale                factor k in (0, 1] applied to the demand by the rate limit (1: none)
    singularity_measure  m = sqrt(det(J J^T)) of the unit-h Jacobian (0 at a singularity)
    rank                 numerical rank of J used by the law (3 unless singular)
    status               "ok" or "+"-joined flags: rate_limited, rank_deficient, lp_failed
    """

    beta_rate: np.ndarray
    hdot_delivered: np.ndarray
    scale: float
    singularity_measure: float
    rank: int
    status: str


def status_string(rate_limited: bool, rank_deficient: bool = False, lp_failed: bool = False) -> str:
    """Join the flags that apply into the status string ("ok" when none do)."""
    flags = [name for name, on in ((RANK_DEFICIENT, rank_deficient), (LP_FAILED, lp_failed),
                                   (RATE_LIMITED, rate_limited)) if on]
    return "+".join(flags) if flags else OK


def limited_result(J, h, beta_rate, beta_rate_max, measure, rank, lp_failed=False) -> SteeringResult:
    """Rate-limit beta_rate (eq. 4) and pack it with the momentum rate it delivers, h J beta'."""
    beta_rate, k = apply_rate_limit(beta_rate, beta_rate_max)
    return SteeringResult(beta_rate, h * (J @ beta_rate), k, measure, rank,
                          status_string(k < 1.0, rank < 3, lp_failed))
