"""Gravity-gradient torque on a body of inertia I about its centre of mass (Hughes,
*Spacecraft Attitude Dynamics*, eq. 8.6): 3 mu / r^3 (r_hat x I r_hat), body axes."""

from __future__ import annotations

import numpy as np

from testbed.math.cross import cross3
from testbed.orbit.constants import MU_EARTH_M3_S2


def gravity_gradient_torque(r_body, inertia) -> np.ndarray:
    """The torque [N m] for the geocentric position r_body [m] in body axes and the inertia
    about the CoM [kg m^2] in the same axes."""
    r = float(np.linalg.norm(r_body))
    u = np.asarray(r_body, float) / r
    return 3.0 * MU_EARTH_M3_S2 / r**3 * cross3(u, inertia @ u)
