"""Gravity-gradient libration of a rigid body about LVLH on a circular orbit of mean motion n:
the closed-form frequencies of the linearised motion (Wie, *Space Vehicle Dynamics and
Control*, sec. 7.2) and the frequencies a run shows, fitted to its LVLH angles."""

from __future__ import annotations

import math

import numpy as np


def pitch_frequency(inertia, n: float) -> float:
    """Pitch libration [rad/s]: n sqrt(3 (Ix - Iz) / Iy) (x along-track, y opposite the orbit
    normal, z nadir; principal inertia [kg m^2], n [rad/s])."""
    ix, iy, iz = inertia
    return n * math.sqrt(3.0 * (ix - iz) / iy)


def roll_yaw_frequencies(inertia, n: float) -> np.ndarray:
    """The two roll-yaw frequencies [rad/s], ascending: the roots in w^2 of
    w^4 - n^2 (1 + 3 k1 + k1 k3) w^2 + 4 n^4 k1 k3 = 0, k1 = (Iy - Iz)/Ix, k3 = (Iy - Ix)/Iz
    (Wie eq. 7.25; real in the Lagrange region Iy > Ix > Iz)."""
    ix, iy, iz = inertia
    k1, k3 = (iy - iz) / ix, (iy - ix) / iz
    b = 1.0 + 3.0 * k1 + k1 * k3
    root = math.sqrt(b * b - 16.0 * k1 * k3)
    return n * np.sqrt(np.array([(b - root) / 2.0, (b + root) / 2.0]))


def lvlh_angles(quat_lvlh) -> np.ndarray:
    """(roll, pitch, yaw) [rad], (N, 3), of attitudes relative to LVLH (w, x, y, z), to first
    order in the angles: 2 atan2(q_i, w)."""
    q = np.asarray(quat_lvlh, float)
    return 2.0 * np.arctan2(q[:, 1:], q[:, :1])


def fitted_frequencies(t, signals, k: int) -> np.ndarray:
    """The k strongest angular frequencies [rad/s], ascending, shared by the signals x_i(t) on
    the uniform times t [s]: the peaks of the summed FFT power (16x padded, Hann window), refined
    by one least-squares fit of k sinusoids (each signal its own amplitudes and offset) to all
    the samples."""
    t = np.asarray(t, float)
    signals = [x - x.mean() for x in signals]
    padded = 16 * len(t)
    power = sum(np.abs(np.fft.rfft(x * np.hanning(len(x)), padded)) ** 2 for x in signals)
    omega = np.fft.rfftfreq(padded, t[1] - t[0]) * 2 * np.pi
    peaks = [i for i in range(1, len(power) - 1) if power[i - 1] <= power[i] >= power[i + 1]]
    guess = np.sort(omega[sorted(peaks, key=lambda i: -power[i])[:k]])
    per = 2 * k + 1

    def residual(p):
        out = []
        for i, x in enumerate(signals):
            c = p[k + i * per:k + (i + 1) * per]
            out.append(c[-1] + sum(c[2 * j] * np.cos(p[j] * t) + c[2 * j + 1] * np.sin(p[j] * t)
                                   for j in range(k)) - x)
        return np.concatenate(out)

    start = np.concatenate([guess, np.zeros(per * len(signals))])
    from scipy.optimize import least_squares  # on use: at the top it would cost every command start-up time
    return np.sort(least_squares(residual, start).x[:k])
