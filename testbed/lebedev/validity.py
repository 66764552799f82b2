"""When Lebedev's closed-loop observer (eq. 4.6) has left the region where it converges.

The observer's error e = x - z obeys, exactly,

    e' = (J(w_hat, H) - l C) e + F(e),

J(w_hat, H) = I^-1 ([(I w_hat + H) x] - [w_hat x] I) the Jacobian of the body's rates at the
estimate (testbed.lebedev.observer.gyrostat_jacobian: A + DF(z) of eq. 4.2, plus I^-1 [H x] for
the momentum H the gain was designed for) and F the quadratic of eq. 4.2. The gain l places
eig(J - l C) at the design poles only at z = 0; the estimate's own quadratic term moves them by
|a_i| |z|, and once J(w_hat) - l C has an eigenvalue with a positive real part sigma the
linearised error grows instead of decaying. `ErrorGrowth` integrates that rate and declares
the observer diverged when the error's linearisation at the estimate predicts a growth of
e = exp(GROWTH_LIMIT) since it last decayed: the mirror of the design's promise, a decay of e
per 1/|Re mu| seconds (docs/theory/lebedev.md "When the observer leaves its validity").
"""

from __future__ import annotations

import math

import numpy as np

from testbed.lebedev.observer import gyrostat_jacobian
from testbed.pipeline import MethodFailed

# ln of the growth of the linearised error, since it last decayed, that declares divergence
GROWTH_LIMIT = 1.0


def error_matrix(moments, w_hat, momentum, gain_times_c) -> np.ndarray:
    """J(w_hat, H) - l C [1/s], the observer's error dynamics linearised at its estimate w_hat
    [rad/s] (module doc); `moments` (Ix, Iy, Iz) [kg m^2], H [N m s], `gain_times_c` the 3x3
    outer product l p' [1/s]."""
    return gyrostat_jacobian(moments, w_hat, momentum) - gain_times_c


def error_growth_rate(moments, w_hat, momentum, gain, sensor_axis) -> float:
    """Largest real part [1/s] of `error_matrix` for the gain l [1/s] and the sensing axis p: the
    rate the linearised error grows at (< 0: decays)."""
    matrix = error_matrix(moments, w_hat, momentum, np.outer(gain, sensor_axis))
    return float(np.linalg.eigvals(matrix).real.max())


def is_hurwitz(matrix):
    """Whether every eigenvalue of the 3x3 `matrix` has a negative real part, by the Routh-Hurwitz
    conditions on det(sI - M) = s^3 + c1 s^2 + c2 s + c3: c1, c3 > 0 and c1 c2 > c3. A stack
    (..., 3, 3) (a batch's worlds) gives a boolean array of its shape (...)."""
    matrix = np.asarray(matrix, float)
    # one matrix in plain floats (every control period asks), a stack by its nine entries' arrays
    a, b, c, d, e, f, g, h, i = matrix.ravel().tolist() if matrix.ndim == 2 else matrix.reshape(-1, 9).T
    c1 = -(a + e + i)
    c2 = a * e - b * d + a * i - c * g + e * i - f * h
    c3 = -(a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g))
    verdict = (c1 > 0.0) & (c3 > 0.0) & (c1 * c2 > c3)
    return verdict if matrix.ndim == 2 else verdict.reshape(matrix.shape[:-2])


class ErrorGrowth:
    """ln of the growth the observer's linearised error has been promised since it last decayed:
    g = max(0, g + sigma h) over each interval h [s] of growth rate sigma (`error_growth_rate`
    at the interval's end). `advance` raises MethodFailed once g reaches GROWTH_LIMIT. Omega
    [rad/s] the spin the estimate deviates from, H [N m s] the momentum the gain was placed for."""

    def __init__(self, moments, spin_rate: float, momentum, gain, sensor_axis):
        self.moments, self.spin_rate = np.asarray(moments, float), float(spin_rate)
        self.momentum = np.asarray(momentum, float)
        self.gain_times_c = np.outer(gain, sensor_axis)   # l C
        self.log_growth = 0.0
        self.since: float | None = None  # when the current growth began [s]

    def advance(self, t: float, h: float, w_hat) -> None:
        """Account the interval of length h [s] ending at t [s] with the estimate w_hat [rad/s]."""
        matrix = error_matrix(self.moments, w_hat, self.momentum, self.gain_times_c)
        if self.log_growth == 0.0 and is_hurwitz(matrix):
            return   # decaying and nothing owed: g stays 0 (the eigenvalues are not needed)
        sigma = float(np.linalg.eigvals(matrix).real.max())
        if self.log_growth == 0.0 and sigma > 0.0:
            self.since = t - h
        self.log_growth = max(0.0, self.log_growth + sigma * h)
        if self.log_growth >= GROWTH_LIMIT:
            raise MethodFailed(
                f"the observer diverged: its error dynamics linearised at the estimate, J(w_hat) - l C, "
                f"have been unstable since t = {self.since:.6g} s (now {sigma:.3g} 1/s, a growth of "
                f"{math.exp(self.log_growth):.3g} since), the estimate |w_hat - Omega e_z| = "
                f"{np.degrees(np.linalg.norm(w_hat - [0.0, 0.0, self.spin_rate])):.3g} deg/s")
