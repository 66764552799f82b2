"""The LVLH (Hill) frame of an ECI position and velocity: x along-track (completes the triad,
along v on a circular orbit), y opposite the orbit normal (-h/|h|, h = r x v), z nadir (-r/|r|).
Its rotation rate relative to ECI is |h|/r^2 about the orbit normal: (0, -|h|/r^2, 0) in LVLH
axes (docs/theory/environment.md, "Frames")."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from testbed.math.cross import cross3


def lvlh_matrix(r, v) -> np.ndarray:
    """Columns: the LVLH axes x, y, z in ECI (the matrix maps LVLH components to ECI)."""
    r = np.asarray(r, float)
    h = cross3(r, v)
    z = -r / math.sqrt(r @ r)
    y = -h / math.sqrt(h @ h)
    return np.column_stack([cross3(y, z), y, z])


def lvlh_quat(r, v) -> np.ndarray:
    """The LVLH attitude (w, x, y, z), LVLH to ECI (MuJoCo's mju_mat2Quat of `lvlh_matrix`)."""
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, lvlh_matrix(r, v).ravel())
    return quat


def lvlh_rate(r, v) -> tuple[np.ndarray, np.ndarray]:
    """(omega, omega') of LVLH relative to ECI, LVLH axes [rad/s, rad/s^2]: omega = (0, -|h|/r^2, 0),
    and with |h| held (two-body) its derivative (0, 2 |h| (r . v) / r^4, 0)."""
    r = np.asarray(r, float)
    r2 = float(r @ r)
    h_vector = cross3(r, v)
    h = math.sqrt(h_vector @ h_vector)
    return np.array([0.0, -h / r2, 0.0]), np.array([0.0, 2.0 * h * float(r @ v) / (r2 * r2), 0.0])
