"""Reference integration of a gyrostat: a rigid carrier with internal rotor momentum h.

Body-frame equation (Wittenburg, Dynamics of Systems of Rigid Bodies, §4.2; Hughes,
Spacecraft Attitude Dynamics, §3.4 and §7; the paper 003's eq. (1) with lambda = h):

    I w' + w x (I w + h) = -h'

I is the total inertia of carrier + rotors (a full symmetric 3x3 tensor is allowed),
h the rotors' momentum relative to the carrier, in body axes.  With no external torque
the body-frame total momentum L = I w + h has constant magnitude
(L' = -w x L); for constant h the kinetic energy (1/2) w.I w is also conserved
(w . (w x L) = 0).  Solved with scipy's DOP853 at rtol 1e-12 (a reference, not a
real-time plant).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from testbed.errors import InputError
from testbed.math.validation import inertia_matrix, vector3

RTOL = 1e-12


def _times(t) -> np.ndarray:
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if t.ndim != 1 or t.size == 0 or not np.all(np.isfinite(t)):
        raise InputError("t", "must be a non-empty 1-D array of finite times")
    if t[0] < 0.0 or np.any(np.diff(t) < 0.0):
        raise InputError("t", "times must be >= 0 and non-decreasing (the state is given at t = 0)")
    return t


def gyrostat_rhs(inertia, h: Callable[[float], np.ndarray], h_dot: Callable[[float], np.ndarray]):
    """The right-hand side f(t, w) = I^-1 (-(w x (I w + h(t))) - h'(t)) for solve_ivp."""
    inv = np.linalg.inv(inertia)

    def rhs(t, w):
        return inv @ (-np.cross(w, inertia @ w + h(t)) - h_dot(t))

    return rhs


def gyrostat_omega(inertia, h_body, omega0, t, h_dot=None, rtol: float = RTOL,
                   atol: float | None = None) -> np.ndarray:
    """Body-frame angular velocity w(t) (rad/s), shape (len(t), 3), of a torque-free gyrostat.

    inertia: total inertia (kg m^2), 3 principal moments or a symmetric 3x3 tensor.
    h_body: rotor momentum relative to the body (N m s, body axes): a constant 3-vector,
        or a callable h(t) -> 3-vector, in which case h_dot(t) -> 3-vector (its time
        derivative, N m) is required.
    omega0: w at t = 0.  t: non-decreasing times >= 0 (s).
    Integrates I w' + w x (I w + h) = -h' with DOP853 (rtol 1e-12 by default; atol
    defaults to 1e-15 of the problem's rate scale |w0| + |h| / I_min).
    """
    inertia = inertia_matrix("inertia", inertia)
    w0 = vector3("omega0", omega0)
    t = _times(t)
    if callable(h_body):
        if h_dot is None or not callable(h_dot):
            raise InputError("h_dot", "a time-varying h_body(t) needs its derivative h_dot(t)")
        h_fun, hd_fun = h_body, h_dot
        h_scale = float(np.linalg.norm(vector3("h_body(0)", h_body(0.0))))
    else:
        if h_dot is not None:
            raise InputError("h_dot", "only allowed with a callable h_body")
        h_const = vector3("h_body", h_body)
        zero = np.zeros(3)
        h_fun, hd_fun = (lambda _t: h_const), (lambda _t: zero)
        h_scale = float(np.linalg.norm(h_const))
    if atol is None:
        # Absolute tolerance scaled to the rates the problem can reach (why: a fixed
        # 1e-15 is meaningless for deg/s spacecraft and too tight for rad/s rotors).
        rate_scale = np.linalg.norm(w0) + h_scale / np.linalg.eigvalsh(inertia)[0]
        atol = 1e-15 * max(rate_scale, np.finfo(float).tiny)
    out = np.empty((t.size, 3))
    if t[-1] == 0.0:
        out[:] = w0
        return out
    from scipy.integrate import solve_ivp  # on use: at the top it would cost every command start-up time
    sol = solve_ivp(gyrostat_rhs(inertia, h_fun, hd_fun), (0.0, t[-1]), w0,
                    method="DOP853", rtol=rtol, atol=atol, t_eval=t)
    if not sol.success:
        raise RuntimeError(f"gyrostat integration failed: {sol.message}")
    return sol.y.T.copy()


def gyrostat_momentum(inertia, h_body, omega) -> np.ndarray:
    """Body-frame total angular momentum L = I w + h (N m s); omega (n, 3), h (3,) or (n, 3)."""
    inertia = inertia_matrix("inertia", inertia)
    return np.atleast_2d(omega) @ inertia.T + np.asarray(h_body, dtype=float)


def gyrostat_energy(inertia, omega) -> np.ndarray:
    """Carrier-motion kinetic energy (1/2) w . I w (J) for each row of omega (n, 3)."""
    inertia = inertia_matrix("inertia", inertia)
    w = np.atleast_2d(omega)
    return 0.5 * np.einsum("ni,ij,nj->n", w, inertia, w)
