"""The Sun's position from the Astronomical Almanac's low-precision formulae (about 0.01 deg
from 1950 to 2050; The Astronomical Almanac, section C, "Low precision formulas for the Sun")
and the Earth's cylindrical shadow."""

from __future__ import annotations

import math

import numpy as np

from testbed.orbit.constants import AU_M, EARTH_RADIUS_M, J2000_JD


def sun_position(jd: float) -> np.ndarray:
    """Geocentric Sun position, mean equator and equinox of date [m], at Julian date `jd`:
    L = 280.460 + 0.9856474 n, g = 357.528 + 0.9856003 n (deg, n = jd - 2451545.0),
    lambda = L + 1.915 sin g + 0.020 sin 2g, eps = 23.439 - 4e-7 n,
    R = 1.00014 - 0.01671 cos g - 0.00014 cos 2g [AU]."""
    n = jd - J2000_JD
    g = math.radians((357.528 + 0.9856003 * n) % 360.0)
    lam = math.radians((280.460 + 0.9856474 * n) % 360.0 + 1.915 * math.sin(g) + 0.020 * math.sin(2 * g))
    eps = math.radians(23.439 - 4e-7 * n)
    distance = (1.00014 - 0.01671 * math.cos(g) - 0.00014 * math.cos(2 * g)) * AU_M
    return distance * np.array([math.cos(lam), math.cos(eps) * math.sin(lam), math.sin(eps) * math.sin(lam)])


def in_cylindrical_shadow(r, sun, radius: float = EARTH_RADIUS_M) -> bool:
    """True when the position r [m] is behind the Earth (r . s < 0, s the unit Sun direction)
    and within `radius` of the Earth-Sun line: |r - (r . s) s| < R."""
    r = np.asarray(r, float)
    s = np.asarray(sun, float) / np.linalg.norm(sun)
    along = float(r @ s)
    return along < 0.0 and float(np.linalg.norm(r - along * s)) < radius
