"""The geomagnetic field as a tilted dipole of IGRF-13's first-degree coefficients (epoch
2020): B = B0 (R/r)^3 (3 (m . r_hat) r_hat - m), m = (g11, h11, g10) / B0 in Earth-fixed axes
(Wertz, *Spacecraft Attitude Determination and Control*, eq. H-18), turned into ECI by the
Greenwich mean sidereal angle (Vallado eq. 3-47)."""

from __future__ import annotations

import math

import numpy as np

from testbed.orbit.constants import EARTH_RADIUS_M, J2000_JD

G10_T, G11_T, H11_T = -29404.8e-9, -1450.9e-9, 4652.5e-9   # IGRF-13, 2020.0
DIPOLE_STRENGTH_T = math.sqrt(G10_T**2 + G11_T**2 + H11_T**2)
DIPOLE_AXIS_ECEF = np.array([G11_T, H11_T, G10_T]) / DIPOLE_STRENGTH_T   # points to the south


def greenwich_angle(jd: float) -> float:
    """Greenwich mean sidereal angle [rad]: 280.46061837 + 360.98564736629 (jd - 2451545.0) deg."""
    return math.radians((280.46061837 + 360.98564736629 * (jd - J2000_JD)) % 360.0)


def dipole_field(r_eci, jd: float) -> np.ndarray:
    """B [T] in ECI at the ECI position r [m] and Julian date jd."""
    theta = greenwich_angle(jd)
    c, s = math.cos(theta), math.sin(theta)
    m = np.array([c * DIPOLE_AXIS_ECEF[0] - s * DIPOLE_AXIS_ECEF[1],
                  s * DIPOLE_AXIS_ECEF[0] + c * DIPOLE_AXIS_ECEF[1], DIPOLE_AXIS_ECEF[2]])
    r = np.asarray(r_eci, float)
    distance = float(np.linalg.norm(r))
    u = r / distance
    return DIPOLE_STRENGTH_T * (EARTH_RADIUS_M / distance) ** 3 * (3.0 * float(m @ u) * u - m)
