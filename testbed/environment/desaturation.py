"""The cross-product momentum-desaturation law (Camillo and Markley, AIAA 80-1820; Markley
and Crassidis, *Fundamentals of Spacecraft Attitude Determination and Control*, eq. 7.110):
m = k (dH x B) / |B|^2 with dH = H - H_target, so that the magnetorquers' torque
m x B = -k dH_perp removes the part of the momentum error across the field at the rate k.
Each dipole axis is then clipped to its limit, the direction kept (the whole vector scaled), so
|m_i| <= m_max,i holds exactly."""

from __future__ import annotations

import numpy as np


def desaturation_dipole(momentum, target, field, gain: float, max_dipole) -> np.ndarray:
    """The commanded dipole [A m^2] for the cluster momentum and its target [N m s], the
    measured field [T] (all body axes), the gain k [1/s] and the per-axis limits [A m^2]."""
    b = np.asarray(field, float)
    b2 = float(b @ b)
    if b2 == 0.0:
        return np.zeros(3)
    dipole = gain * np.cross(np.asarray(momentum, float) - target, b) / b2
    limit = np.asarray(max_dipole, float)
    worst = float(np.max(np.abs(dipole) / limit))
    if worst <= 1.0:
        return dipole
    # dipole / worst puts the worst axis on its limit up to one rounding (|m_i| / m_max,i may
    # read 1 + 2^-52); the clip, exact, removes that and moves the direction by one ulp at most
    return np.clip(dipole / worst, -limit, limit)
