"""Reference geometry of the coplanar "rhombus" 4-CMG cluster (SEEDS §004 eq. (15), (18)).

For tests, benchmarks and analytic checks; a simulation reads J from its MuJoCo model.
"""

from __future__ import annotations

import numpy as np


def rhombus_momentum(beta: np.ndarray, alpha: float) -> np.ndarray:
    """Unit-h cluster momentum H/h (eq. 15) for gimbal angles beta (4,) and skew angle alpha."""
    c, s = np.cos(beta), np.sin(beta)
    return np.array([np.cos(alpha) * (c[0] - c[1] - c[2] + c[3]),
                     np.sin(alpha) * (c[0] + c[1] - c[2] - c[3]),
                     s[0] + s[1] - s[2] - s[3]])


def rhombus_jacobian(beta: np.ndarray, alpha: float) -> np.ndarray:
    """J = d(H/h)/d(beta) (3x4) of eq. (15); eq. (18) is this with cos/sin(alpha) = 1."""
    c, s = np.cos(beta), np.sin(beta)
    return np.array([np.cos(alpha) * np.array([-s[0], s[1], s[2], -s[3]]),
                     np.sin(alpha) * np.array([-s[0], -s[1], s[2], s[3]]),
                     [c[0], c[1], -c[2], -c[3]]])
