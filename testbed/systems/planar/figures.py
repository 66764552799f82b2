"""Figures of a planar closed loop measured from sampled trajectories, without the model.

Pure functions on recorded arrays (times, states); metrics.py compares what
they return with the closed forms of Avdeev & Kaptsova 2016 (akor_regulator.py).
"""

from __future__ import annotations

import numpy as np


def identify_poles(t: np.ndarray, x: np.ndarray, floor: float = 1e-9) -> np.ndarray:
    """Continuous-time poles of an autonomous 2-state linear system from its samples.

    Free decay x(t_n) at a uniform step h obeys x_{n+1} = F x_n exactly (F = expm(A h)
    for a continuous loop, the one-period map for a sampled one). F is fitted by least
    squares over the samples whose size is above `floor` times the first one (below it,
    round-off dominates); the poles are log(eig F) / h. A fit of the whole decay, real,
    double and complex roots alike (a vector form of Prony's method).
    """
    t, x = np.asarray(t, float), np.asarray(x, float)
    h = float(np.median(np.diff(t)))
    if not np.allclose(np.diff(t), h, rtol=1e-6, atol=1e-12):
        raise ValueError("identify_poles needs uniformly spaced samples")
    scale = np.max(np.abs(x), axis=0)
    scale[scale == 0] = 1.0
    z = x / scale                          # angle and rate on a common scale
    size = np.linalg.norm(z, axis=1)
    keep = np.nonzero(size > floor * size[0])[0]
    n = int(keep[-1]) + 1 if keep.size else 0
    if n < 4:
        raise ValueError("too few samples above the round-off floor to identify the poles")
    Ft, *_ = np.linalg.lstsq(z[: n - 1], z[1:n], rcond=None)  # z[1:] = z[:-1] F^T
    eig = np.linalg.eigvals(Ft.T).astype(complex)
    return np.log(eig) / h


def stability_margin_from_poles(poles: np.ndarray) -> float:
    """eta: distance of the nearest pole to the imaginary axis (Avdeev & Kaptsova, text of eq. 12)."""
    return float(-np.max(poles.real))


def settling_time(t: np.ndarray, y: np.ndarray, final: float, band: float = 0.05) -> float:
    """Last time |y - final| leaves band * |y(0) - final| (the "95 %" settling time).

    Linear interpolation between the last sample outside the band and the next one; NaN if
    the signal is still outside the band at the last sample.
    """
    t, y = np.asarray(t, float), np.asarray(y, float)
    e = np.abs(y - final)
    limit = band * e[0]
    outside = np.nonzero(e > limit)[0]
    if outside.size == 0:
        return 0.0
    i = int(outside[-1])
    if i == len(t) - 1:
        return float("nan")
    return float(t[i] + (e[i] - limit) / (e[i] - e[i + 1]) * (t[i + 1] - t[i]))


def steady_line(t: np.ndarray, x: np.ndarray, fraction: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
    """(value at the last sample, slope) of a straight line fitted to the last `fraction` of x.

    A steady state under m = m0 + m0' t is x = p + q t (eq. 14-15): the fit gives it without
    the model, once the transient has died out.
    """
    t, x = np.asarray(t, float), np.asarray(x, float)
    n = max(3, int(len(t) * fraction))
    tt, xx = t[-n:] - t[-1], x[-n:]
    design = np.column_stack([np.ones(n), tt])
    coef, *_ = np.linalg.lstsq(design, xx, rcond=None)
    return coef[0], coef[1]


def peak(t: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """(t, y) of the largest sample, refined by the parabola through it and its neighbours."""
    t, y = np.asarray(t, float), np.asarray(y, float)
    i = int(np.argmax(y))
    if i == 0 or i == len(y) - 1:
        return float(t[i]), float(y[i])
    y0, y1, y2 = y[i - 1], y[i], y[i + 1]
    denom = y0 - 2 * y1 + y2
    if denom >= 0:
        return float(t[i]), float(y1)
    d = 0.5 * (y0 - y2) / denom             # offset in samples, |d| <= 1/2
    h = 0.5 * (t[i + 1] - t[i - 1])
    return float(t[i] + d * h), float(y1 - 0.25 * (y0 - y2) * d)
