"""The value an environment torque is held at over its update period: the linear
extrapolation of its last two samples to the period's midpoint (a second-order hold,
docs/theory/environment.md "The hold"). A zero-order hold of the sample itself lags the
torque by half a period, which acts as a negative damping ~omega^2 h / 4 on any motion the
torque sets (libration grows at first order in h); the midpoint value makes each period's
impulse right to O(h^3), so what is left is a frequency error ~(omega h)^2 and no growth."""

from __future__ import annotations

import numpy as np


class MidpointHold:
    """y_hold = y_k + (h / 2) (y_k - y_(k-1)) / (t_k - t_(k-1)) for the period h [s] that
    starts at t_k; the sample itself (a zero-order hold) at the first update, after a gap or
    a step back in time, and where the caller says the value jumped (`smooth=False`)."""

    def __init__(self, period: float):
        self.period = period
        self._time = None
        self._value = None

    def __call__(self, t: float, value: np.ndarray, smooth: bool = True) -> np.ndarray:
        """The value [its own units] to hold over [t, t + period] given the sample `value` at t [s]."""
        last_time, last_value = self._time, self._value
        self._time, self._value = t, value
        if last_time is None or not smooth:
            return value
        gap = t - last_time
        if not 0.0 < gap <= 1.5 * self.period:  # restarted, or not the previous update: nothing to extrapolate from
            return value
        return value + (0.5 * self.period / gap) * (value - last_value)
