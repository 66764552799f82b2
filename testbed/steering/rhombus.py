"""Reference geometry of the coplanar "rhombus" 4-CMG cluster (SEEDS §004 eq. (15), (18)).

For tests, benchmarks and analytic checks; a simulation reads J from its MuJoCo model. The
axes e_i, s_i z come from the one definition, testbed.domains.cmg_rhombus.rhombus_axes.
"""

from __future__ import annotations

import numpy as np

from testbed.domains.cmg_rhombus import rhombus_axes


def rhombus_momentum(beta: np.ndarray, alpha: float) -> np.ndarray:
    """Unit-h cluster momentum H/h = sum_i cos b_i e_i + sin b_i s_i z (eq. 15)."""
    e, _, sz = rhombus_axes(alpha)
    beta = np.asarray(beta, dtype=float)
    return np.cos(beta) @ e + np.sin(beta) @ sz


def rhombus_jacobian(beta: np.ndarray, alpha: float) -> np.ndarray:
    """J = d(H/h)/d(beta) (3x4) of eq. (15): column i = -sin b_i e_i + cos b_i s_i z (eq. 18)."""
    e, _, sz = rhombus_axes(alpha)
    beta = np.asarray(beta, dtype=float)[:, None]
    return (-np.sin(beta) * e + np.cos(beta) * sz).T
