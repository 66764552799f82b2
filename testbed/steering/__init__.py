"""CMG steering laws: gimbal rates beta' (n,) that deliver a wanted momentum rate H'.

The cluster obeys h J(beta) beta' = H' (SEEDS §004 eq. 17), J the 3xn unit-h Jacobian of n = 3 ... 8
units supplied by the caller (FOUR_UNIT_LAWS: those that take n = 4 only). Every law has the signature

    law(J, h, Hdot, beta_rate_max, **options) -> SteeringResult

and never commands |beta'_i| > beta_rate_max: it scales the demand by the largest k in
(0, 1] that fits, keeping its direction. At rank J < 3 the pseudo-inverse and min-max laws
deliver the least-squares projection of H' onto range(J); SR/GSR damp instead.

    pinv        pseudo-inverse, eq. (20) corrected             pseudo_inverse.py
    sr          Nakamura-Hanafusa singularity-robust inverse   sr_inverse.py
    gsr         Wie's generalized SR inverse (dithered)        sr_inverse.py
    minimax_lp  min-max, eq. (21)-(28), scipy HiGHS LP         minimax_lp.py
    minimax     min-max, exact closed form (~us)               minimax_exact.py
    minimax_avoid  min-max under a barrier on sqrt(det(J J^T)),  minimax_avoid.py
                   pulled back to the start's zero-momentum family
    osr         Wie's off-diagonal SR inverse (2005)           off_diagonal_sr.py
    sda         Ford-Hall singular-direction avoidance (2000)  singular_direction_avoidance.py
    pga         Vadali's preferred-gimbal-angle null motion    preferred_gimbal_angles.py

Some keyword arguments are not options a user sets but what the caller knows at each step
(STEP_INPUTS): `t` the time (gsr, osr), `column_derivative` dJ_i/dbeta_i (minimax_avoid),
`rate_bounds` per-gimbal bounds on beta'_i from angle and acceleration limits (gimbal_limits.py),
and for minimax_avoid's pull back to the start (and pga's null motion): `gimbal_angle` (the angles J is taken at),
`preferred_gimbal_angles` and `preferred_jacobian` (the run's first angles and J there) and
`peak_rate_so_far` (the largest |beta'_i| commanded so far).
"""

from __future__ import annotations

import inspect

from testbed.errors import InputError
from testbed.steering.minimax_avoid import minimax_avoid_steering
from testbed.steering.minimax_exact import minimax_steering
from testbed.steering.minimax_lp import minimax_lp_steering
from testbed.steering.off_diagonal_sr import osr_steering
from testbed.steering.preferred_gimbal_angles import pga_steering
from testbed.steering.pseudo_inverse import pinv_steering
from testbed.steering.result import SteeringResult
from testbed.steering.singular_direction_avoidance import sda_steering
from testbed.steering.sr_inverse import gsr_steering, sr_steering

STEERING_LAWS = {
    "pinv": pinv_steering,
    "sr": sr_steering,
    "gsr": gsr_steering,
    "minimax_lp": minimax_lp_steering,
    "minimax": minimax_steering,
    "minimax_avoid": minimax_avoid_steering,
    "osr": osr_steering,
    "sda": sda_steering,
    "pga": pga_steering,
}

# Laws that steer 4-unit clusters only, with the reason (the stage refuses any other array before the run).
FOUR_UNIT_LAWS = {"minimax_avoid": "its barrier and its pull back work on the one-dimensional null space of 4 units"}

# Keyword arguments a caller supplies at each step (see the module doc), not user options.
STEP_INPUTS = frozenset({"t", "column_derivative", "rate_bounds", "gimbal_angle", "preferred_gimbal_angles",
                         "preferred_jacobian", "peak_rate_so_far"})

# Keyword options each law accepts, read from its signature.
LAW_OPTIONS = {name: tuple(p.name for p in inspect.signature(law).parameters.values()
                           if p.kind is inspect.Parameter.KEYWORD_ONLY)
               for name, law in STEERING_LAWS.items()}


def steering_law(name: str):
    """The law registered under `name`, or InputError("steering.law", ...)."""
    try:
        return STEERING_LAWS[name]
    except (KeyError, TypeError):
        raise InputError("steering.law", f"unknown law {name!r}; choose one of "
                         f"{', '.join(STEERING_LAWS)}") from None


def steer(name: str, J, h, Hdot, beta_rate_max, **options) -> SteeringResult:
    """Run the law `name`; unknown options raise InputError("steering.<option>", ...)."""
    law = steering_law(name)
    for option in options:
        if option not in LAW_OPTIONS[name]:
            allowed = ", ".join(LAW_OPTIONS[name]) or "none"
            raise InputError(f"steering.{option}", f"not an option of law {name!r} "
                             f"(options: {allowed})")
    return law(J, h, Hdot, beta_rate_max, **options)


__all__ = ["STEERING_LAWS", "LAW_OPTIONS", "STEP_INPUTS", "SteeringResult", "steer", "steering_law",
           "pinv_steering", "sr_steering", "gsr_steering", "minimax_lp_steering",
           "minimax_steering", "minimax_avoid_steering", "osr_steering", "sda_steering", "pga_steering"]
