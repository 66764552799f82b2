"""The classical fixed-step fourth-order Runge-Kutta method, shared by every in-loop integrator
(observers that run their own model between samples)."""

from __future__ import annotations

from typing import Callable

import numpy as np


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
