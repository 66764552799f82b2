"""The rhombus cluster written out from SEEDS §004 eq. (15) and (18), independently of the
model code, as the reference the model-read ClusterGeometry and the steering laws are held to."""

from __future__ import annotations

import numpy as np

SIGNS = np.array([1.0, 1.0, -1.0, -1.0])  # s_i


def rhombus_axes(alpha: float):
    """e_i (spin at beta = 0) and s_i z (where the spin axis turns for beta > 0), each (4, 3)."""
    c, s = np.cos(alpha), np.sin(alpha)
    e = np.array([[c, s, 0.0], [-c, s, 0.0], [-c, -s, 0.0], [c, -s, 0.0]])
    return e, SIGNS[:, None] * np.array([0.0, 0.0, 1.0])


def rhombus_momentum(beta: np.ndarray, alpha: float) -> np.ndarray:
    """Unit-h cluster momentum H/h = sum_i cos b_i e_i + sin b_i s_i z (eq. 15)."""
    e, sz = rhombus_axes(alpha)
    beta = np.asarray(beta, dtype=float)
    return np.cos(beta) @ e + np.sin(beta) @ sz


def rhombus_jacobian(beta: np.ndarray, alpha: float) -> np.ndarray:
    """J = d(H/h)/d(beta) (3x4) of eq. (15): column i = -sin b_i e_i + cos b_i s_i z (eq. 18)."""
    e, sz = rhombus_axes(alpha)
    beta = np.asarray(beta, dtype=float)[:, None]
    return (-np.sin(beta) * e + np.cos(beta) * sz).T


def rhombus_column_derivative(beta: np.ndarray, alpha: float) -> np.ndarray:
    """dJ_i/dbeta_i (3x4) of eq. (18): column i = -cos b_i e_i - sin b_i s_i z (minus the spin axis)."""
    e, sz = rhombus_axes(alpha)
    beta = np.asarray(beta, dtype=float)[:, None]
    return -(np.cos(beta) * e + np.sin(beta) * sz).T
