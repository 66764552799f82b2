"""The classical fixed-step fourth-order Runge-Kutta method, shared by every in-loop integrator
(observers that run their own model between samples)."""

from __future__ import annotations

from typing import Callable

import numpy as np

from testbed.errors import InputError


def rk4_steps(f: Callable[[float, np.ndarray], np.ndarray], y: np.ndarray, duration: float,
              n: int) -> np.ndarray:
    """y after n equal RK4 steps of y' = f(s, y) over `duration` [s].

    s in [0, 1] is the fraction of the interval elapsed at each stage (0, 1/2 and 1 of a
    step), so an input held or interpolated over the interval is evaluated where it acts:
        k1 = f(s_k, y), k2 = f(s_k + 1/2n, y + h/2 k1), k3 = f(s_k + 1/2n, y + h/2 k2),
        k4 = f(s_k + 1/n, y + h k3),  y <- y + h/6 (k1 + 2 k2 + 2 k3 + k4),  h = duration / n.
    """
    h = duration / n
    for k in range(n):
        s0, s1 = k / n, (k + 1) / n
        mid = (s0 + s1) / 2
        k1 = f(s0, y)
        k2 = f(mid, y + h / 2 * k1)
        k3 = f(mid, y + h / 2 * k2)
        k4 = f(s1, y + h * k3)
        y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return y


def rk4_amplification(z):
    """R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24: one RK4 step of length h multiplies a mode
    y' = lambda y by R(lambda h) (the method's stability function; |R| < 1 is its stability
    region, which meets the negative real axis at z = -2.785)."""
    z = np.asarray(z, complex)
    return 1 + z * (1 + z / 2 * (1 + z / 3 * (1 + z / 4)))


def check_rk4_stable(eigenvalues, step: float, field: str) -> None:
    """Refuse linear modes y' = lambda y that RK4 steps of `step` [s] would not damp
    (|R(lambda h)| >= 1, `rk4_amplification`): the integrated error would grow where the
    design says it decays, and overflow within a few steps."""
    with np.errstate(over="ignore", invalid="ignore"):   # a pole of 1e300 1/s: R overflows, refused below
        growth = np.abs(rk4_amplification(np.asarray(eigenvalues, complex) * float(step)))
    growth = np.where(np.isnan(growth), np.inf, growth)
    worst = int(np.argmax(growth))
    if not growth[worst] < 1.0:
        pole = complex(np.asarray(eigenvalues, complex)[worst])
        shown = f"{pole.real:.4g}" if pole.imag == 0 else f"{pole.real:.4g}{pole.imag:+.4g}i"
        raise InputError(field, f"pole {shown} 1/s is outside the stability region of the RK4 substeps "
                                f"of {step:.4g} s that integrate it (|R(p h)| = {growth[worst]:.3g} >= 1; a real "
                                f"pole needs |p| h < 2.785): take slower poles or a shorter max_substep_s")
