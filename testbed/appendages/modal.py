"""The modes MuJoCo gives a model: from its linearised step map, and from a free-decay history.

Linearised: `mjd_transitionFD` gives the step map's Jacobian A (MuJoCo's tangent space, a
rotation as 3 numbers); each eigenvalue z of A is exp(s dt) of a continuous-time pole s, so
s = log(z) / dt, w_n = |s| and zeta = -Re s / |s|. MuJoCo differentiates no RK4 step: the map
is a semi-implicit Euler step of LINEARISATION_STEP_S, whose z = exp(+-i phi) has
phi = 2 asin(w dt / 2): the frequency read is w (1 + (w dt)^2 / 24), within 1e-6 below 50 rad/s;
its implicit damping moves a damped pole by O(c dt / m) (2e-5 at zeta = 0.04, w = 2 rad/s). Free decay: successive peaks of a decaying
oscillation give the damped period and the logarithmic decrement delta; zeta = delta /
sqrt(4 pi^2 + delta^2) and w_n = w_d / sqrt(1 - zeta^2) (docs/theory/flexible.md, eq. F9).
"""

from __future__ import annotations

import copy

import mujoco
import numpy as np

from testbed.appendages.closed_form import Modes

FD_EPSILON = 1e-6  # the finite-difference step of mjd_transitionFD (centred)
LINEARISATION_STEP_S = 1e-4


def linearised_modes(model: mujoco.MjModel, data: mujoco.MjData) -> Modes:
    """The oscillatory modes of `model` about the state in `data` (an equilibrium: at rest):
    every pole with Im s > 0 of the linearised step (module doc), lowest frequency first."""
    euler = copy.copy(model)
    euler.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    euler.opt.timestep = LINEARISATION_STEP_S
    size = 2 * model.nv + model.na
    transition = np.zeros((size, size))
    mujoco.mjd_transitionFD(euler, data, FD_EPSILON, True, transition, None, None, None)
    s = np.log(np.linalg.eigvals(transition).astype(complex)) / LINEARISATION_STEP_S
    oscillating = s[s.imag > 1e-9 / LINEARISATION_STEP_S]
    oscillating = oscillating[np.argsort(np.abs(oscillating))]
    return Modes(np.abs(oscillating), -oscillating.real / np.abs(oscillating))


def _peaks(time: np.ndarray, signal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Times [s] and values of the local maxima of a sampled signal, each refined by the parabola
    through it and its two neighbours."""
    inside = np.flatnonzero((signal[1:-1] > signal[:-2]) & (signal[1:-1] >= signal[2:])) + 1
    left, mid, right = signal[inside - 1], signal[inside], signal[inside + 1]
    curvature = left - 2.0 * mid + right
    shift = 0.5 * (left - right) / curvature
    step = time[inside + 1] - time[inside]
    return time[inside] + shift * step, mid - 0.25 * (left - right) * shift


def free_decay(time, signal) -> tuple[float, float]:
    """(w_n [rad/s], zeta) of a single-mode decaying oscillation about zero, from its positive
    peaks: the mean damped period over all of them and the mean log decrement from the first
    to the last (module doc). Raises ValueError with fewer than three peaks."""
    time, signal = np.asarray(time, float), np.asarray(signal, float)
    times, values = _peaks(time, signal)
    keep = values > 0
    times, values = times[keep], values[keep]
    if len(times) < 3:
        raise ValueError(f"a free decay needs three peaks or more, found {len(times)}")
    cycles = len(times) - 1
    damped = 2.0 * np.pi * cycles / (times[-1] - times[0])
    decrement = np.log(values[0] / values[-1]) / cycles
    zeta = decrement / np.sqrt(4.0 * np.pi ** 2 + decrement ** 2)
    return float(damped / np.sqrt(1.0 - zeta ** 2)), float(zeta)
