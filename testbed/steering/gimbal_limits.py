"""Gimbal-angle travel limits and a gimbal-acceleration limit as per-step bounds on the rates.

A steering command beta'_k is held for one control period Tc, so the commanded ("set-point")
angle moves by beta'_k Tc and the commanded acceleration is (beta'_k - beta'_{k-1}) / Tc. With
u = a_max Tc (the most the command may change in one period), each gimbal's next rate must lie
in [lo, hi]:

    hi = min(beta'max, beta'_{k-1} + u, r_stop(beta_max - beta_set))
    lo = max(-beta'max, beta'_{k-1} - u, -r_stop(beta_set - beta_min))

r_stop(d) is the largest rate that may be held for one period with the gimbal still able to stop
within the distance d left to its stop, braking by u per period: r Tc + Tc sum_{j>=1} max(r - j u, 0)
<= d. That total is S(r) = Tc (k + 1) (r - u k / 2) for k = floor(r / u), increasing and piecewise
linear with S(k u) = Tc u k (k + 1) / 2, so

    k = floor((sqrt(1 + 8 d / (Tc u)) - 1) / 2),   r_stop(d) = d / (Tc (k + 1)) + u k / 2,     (1)

and r_stop(d) = d / Tc without an acceleration limit (u infinite). The bounds never contradict
each other when the previous command met them: S(r - u) = S(r) - r Tc, so a rate that could stop
within d can, one period later, slow by u and still stop within d - r Tc; and r_stop >= 0 while
the set-point is within its range. The box therefore always holds the previous rate slowed by u
towards zero, and it holds zero itself unless the acceleration limit forces a gimbal to keep
turning (testbed.steering.rate_limit.apply_rate_bounds handles both cases).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


ACCELERATION_ROUNDING = 1e-9  # relative slack of a count of rate changes over u for the bounds' rounding


def braking_rate(distance, rate_step, period, sqrt=math.sqrt, floor=math.floor):
    """r_stop(d) of eq. (1) [rad/s] for 0 < d and u finite: floats, or arrays elementwise with
    sqrt, floor = np.sqrt, np.floor."""
    k = floor((sqrt(1.0 + 8.0 * distance / (period * rate_step)) - 1.0) / 2.0)
    return distance / (period * (k + 1)) + rate_step * k / 2.0


def stopping_rate(distance: float, rate_step: float, period: float) -> float:
    """r_stop(d) of eq. (1) [rad/s]: distance d [rad] to the stop, rate_step u = a_max Tc [rad/s]
    (math.inf: no acceleration limit), period Tc [s]; 0 for d <= 0, infinite for d infinite."""
    if distance <= 0.0:
        return 0.0
    if math.isinf(distance):
        return math.inf
    if math.isinf(rate_step):
        return distance / period
    return braking_rate(distance, rate_step, period)


def stopping_rates(distance: np.ndarray, rate_step: np.ndarray, period: np.ndarray) -> np.ndarray:
    """`stopping_rate` elementwise on arrays that broadcast (a row per world)."""
    with np.errstate(all="ignore"):  # the cases of the branches below computed and dropped
        braking = braking_rate(distance, rate_step, period, np.sqrt, np.floor)
        free = np.where(np.isinf(rate_step), distance / period, braking)
    return np.where(distance <= 0.0, 0.0, np.where(np.isinf(distance), np.inf, free))


@dataclass(frozen=True)
class GimbalLimits:
    """Per-gimbal angle range [angle_min, angle_max] (4,) [rad] (+-inf: none) and one
    acceleration limit [rad/s^2] (math.inf: none), for commands held over `period` [s]. Of many
    worlds at once: angle_min, angle_max (N, 4) and acceleration_max, period (N, 1), a row each."""

    angle_min: np.ndarray
    angle_max: np.ndarray
    acceleration_max: float
    period: float

    @property
    def rate_step(self) -> float:
        """u = a_max Tc: the most a rate command may change from one period to the next [rad/s]."""
        return self.acceleration_max * self.period

    def rate_bounds(self, setpoint, previous_rate, rate_max: float) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi) (4,) [rad/s] for the next command, from the commanded angles `setpoint` [rad]
        and the previous command [rad/s] (module doc). lo <= hi always (rounding is folded in).
        Of many worlds (limits of rows): setpoint and previous_rate (N, 4), rate_max (N, 1)."""
        u, tc = self.rate_step, self.period
        if np.ndim(setpoint) == 1:  # one world: a float loop costs less than numpy's calls on 4 numbers
            up = np.array([stopping_rate(d, u, tc) for d in self.angle_max - setpoint])
            down = np.array([stopping_rate(d, u, tc) for d in setpoint - self.angle_min])
        else:
            up = stopping_rates(self.angle_max - setpoint, u, tc)
            down = stopping_rates(setpoint - self.angle_min, u, tc)
        hi = np.minimum(np.minimum(rate_max, previous_rate + u), up)
        lo = np.maximum(np.maximum(-rate_max, previous_rate - u), -down)
        return np.minimum(lo, hi), hi
