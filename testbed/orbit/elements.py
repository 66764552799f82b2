"""Classical orbital elements to an ECI position and velocity (Vallado, *Fundamentals of
Astrodynamics*, algorithm 10 COE2RV)."""

from __future__ import annotations

import math

import numpy as np

from testbed.orbit.constants import MU_EARTH_M3_S2


def true_from_mean_anomaly(mean_anomaly: float, e: float) -> float:
    """True anomaly [rad] of the mean anomaly M [rad]: Kepler's equation E - e sin E = M by
    Newton's method, then tan(nu/2) = sqrt((1+e)/(1-e)) tan(E/2) (Vallado algorithm 2)."""
    ecc = mean_anomaly if e < 0.8 else math.pi
    for _ in range(50):
        step = (ecc - e * math.sin(ecc) - mean_anomaly) / (1.0 - e * math.cos(ecc))
        ecc -= step
        if abs(step) < 1e-15:
            break
    return 2.0 * math.atan2(math.sqrt(1.0 + e) * math.sin(ecc / 2), math.sqrt(1.0 - e) * math.cos(ecc / 2))


def state_from_elements(a: float, e: float, i: float, raan: float, argp: float, nu: float,
                        mu: float = MU_EARTH_M3_S2) -> tuple[np.ndarray, np.ndarray]:
    """(r [m], v [m/s]) in ECI of semi-major axis a [m], eccentricity e, inclination i, right
    ascension of the ascending node raan, argument of perigee argp and true anomaly nu [rad]:
    r_pqw = p/(1 + e cos nu) (cos nu, sin nu, 0), v_pqw = sqrt(mu/p) (-sin nu, e + cos nu, 0),
    rotated by R3(-raan) R1(-i) R3(-argp)."""
    p = a * (1.0 - e * e)
    r_pqw = p / (1.0 + e * math.cos(nu)) * np.array([math.cos(nu), math.sin(nu), 0.0])
    v_pqw = math.sqrt(mu / p) * np.array([-math.sin(nu), e + math.cos(nu), 0.0])
    co, so, ci, si, cw, sw = (math.cos(raan), math.sin(raan), math.cos(i), math.sin(i),
                              math.cos(argp), math.sin(argp))
    rot = np.array([[co * cw - so * sw * ci, -co * sw - so * cw * ci, so * si],
                    [so * cw + co * sw * ci, -so * sw + co * cw * ci, -co * si],
                    [sw * si, cw * si, ci]])
    return rot @ r_pqw, rot @ v_pqw
