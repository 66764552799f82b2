"""The allocator `wheel_minimax`: the wheel torques whose largest share of its motor's limit is least.

Among all u with A u = H' (RW-3) it takes the one that minimises max_i |u_i + f_i| / u_max,i (f_i the
friction fed forward), within each wheel's speed bound of (RW-6): a linear program (HiGHS, through
scipy's linprog), variables (u, s), min s subject to A u = H', -s u_max,i <= u_i + f_i <= s u_max,i;
for four wheels (a one-dimensional null space) its closed form, twenty times faster.
A redundant array delivers more torque this way than by the pseudo-inverse, whose answer it equals
when the latter is already min-max (docs/theory/reaction-wheels.md, "Min-max allocation"). When no
u within the limits delivers H' (s > 1, or the speed bounds leave none), the second program takes
the largest share k of it that fits: max k subject to A u = k H', u within the bounds of (RW-6);
the body torque keeps its direction and a saturated wheel no longer stops the others.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.pipeline import stage
from testbed.scenario.schema import param
from testbed.steering.rate_limit import apply_rate_bounds
from testbed.systems.reaction_wheels.allocator import WheelAllocator, speed_bounds


@dataclass(kw_only=True)
class WheelMinimaxParams:
    compensate_friction: bool = param(True, doc="add the bearing friction of each wheel to its motor's command")


def least_largest_torque(distribution, wanted, torque_max, friction, reach):
    """(u, s) [N m, -]: A u = `wanted` with the least s = max_i |u_i + f_i| / u_max,i, each u_i within
    `reach` (lo, hi), its speed_bounds; None when no u within them delivers `wanted`."""
    n = len(torque_max)
    cost = np.zeros(n + 1)
    cost[-1] = 1.0
    identity = np.eye(n)
    upper = np.block([[identity, -torque_max[:, None]], [-identity, -torque_max[:, None]]])
    from scipy.optimize import linprog  # on use: at the top it would cost every command start-up time
    result = linprog(cost, A_ub=upper, b_ub=np.concatenate([-friction, friction]),
                     A_eq=np.hstack([distribution, np.zeros((3, 1))]), b_eq=wanted,
                     bounds=list(zip(*reach)) + [(0.0, None)], method="highs")
    return (result.x[:n], float(result.x[-1])) if result.status == 0 else None


def least_largest_on_a_line(start, null, torque_max, friction, reach):
    """least_largest_torque for an array with a one-dimensional null space: u = u0 + t n (`start` u0 =
    A^+ H', `null` n), where s(t) = max_i |u0_i + f_i + t n_i| / u_max,i is convex and piecewise linear,
    least at a crossing of two of its lines or at an end of the interval of t that `reach` allows.
    None when that interval is empty."""
    lo, hi = reach
    low, high = -np.inf, np.inf
    for u, n, a, b in zip(start, null, lo, hi):
        if n > 0:
            low, high = max(low, (a - u) / n), min(high, (b - u) / n)
        elif n < 0:
            low, high = max(low, (b - u) / n), min(high, (a - u) / n)
        elif not a <= u <= b:
            return None
    if low > high:
        return None
    offset, slope = (start + friction) / torque_max, null / torque_max
    i, j = np.triu_indices(len(start), 1)
    sign = np.repeat([1.0, -1.0], len(i))
    i, j = np.tile(i, 2), np.tile(j, 2)
    run = slope[i] - sign * slope[j]
    crossings = -(offset[i] - sign * offset[j])[run != 0] / run[run != 0]
    candidates = np.clip(np.concatenate([crossings, [low, high]]), low, high)
    candidates = candidates[np.isfinite(candidates)]
    t = candidates[np.argmin(np.max(np.abs(offset + candidates[:, None] * slope), axis=1))]
    u = start + t * null
    return u, float(np.max(np.abs(u + friction) / torque_max))


def largest_share(distribution, wanted, bounds):
    """(u, k): the largest k in [0, 1] with A u = k `wanted` and u within `bounds` (lo, hi) [N m];
    None when not even k = 0 fits (a wheel past its speed limit whose brake no other wheel balances)."""
    n = distribution.shape[1]
    cost = np.zeros(n + 1)
    cost[-1] = -1.0
    from scipy.optimize import linprog
    result = linprog(cost, A_eq=np.hstack([distribution, -np.asarray(wanted)[:, None]]), b_eq=np.zeros(3),
                     bounds=list(zip(*bounds)) + [(0.0, 1.0)], method="highs")
    return (result.x[:n], float(result.x[-1])) if result.status == 0 else None


@stage("allocator", "wheel_minimax", WheelMinimaxParams)
class WheelMinimax(WheelAllocator):
    """Wheel torques of least largest share of their limits (an LP), the largest share of the demand
    the limits allow when it does not fit."""

    def __init__(self, params, ctx):
        super().__init__(params, ctx)
        null_space = np.linalg.svd(self.distribution)[2][3:]
        self.null = null_space[0] if len(null_space) == 1 else None  # four wheels: the closed form

    def distribute(self, wanted, rates, friction, bounds):
        limits, reach = self.array.torque_max, speed_bounds(self.array, rates, self.period)
        if self.null is not None:
            fitted = least_largest_on_a_line(self.inverse @ wanted, self.null, limits, friction, reach)
        else:
            fitted = least_largest_torque(self.distribution, wanted, limits, friction, reach)
        if fitted is not None and fitted[1] <= 1.0:
            return fitted[0], 1.0
        shared = largest_share(self.distribution, wanted, bounds)
        if shared is not None:
            return shared
        return apply_rate_bounds(self.inverse @ wanted, *bounds)  # the brake of (RW-6), as wheel_pinv gives it
