"""Atmospheric density at a geodetic point: the exponential model of Vallado's Table 8-4
(*Fundamentals of Astrodynamics*, 4th ed.; a fixed 1976 US Standard / CIRA-72 fit) at the
height above the WGS-84 ellipsoid, or NRLMSIS 2.1 (the `pymsis` package) at the geodetic
longitude, latitude and height with F10.7 and Ap held at given values, so nothing is downloaded."""

from __future__ import annotations

import numpy as np

# base altitude h0 [km], density at h0 [kg/m^3], scale height H [km] (Vallado Table 8-4)
EXPONENTIAL_TABLE = (
    (100, 5.297e-7, 5.877), (110, 9.661e-8, 7.263), (120, 2.438e-8, 9.473), (130, 8.484e-9, 12.636),
    (140, 3.845e-9, 16.149), (150, 2.070e-9, 22.523), (180, 5.464e-10, 29.740), (200, 2.789e-10, 37.105),
    (250, 7.248e-11, 45.546), (300, 2.418e-11, 53.628), (350, 9.518e-12, 53.298), (400, 3.725e-12, 58.515),
    (450, 1.585e-12, 60.828), (500, 6.967e-13, 63.822), (600, 1.454e-13, 71.835), (700, 3.614e-14, 88.667),
    (800, 1.170e-14, 124.64), (900, 5.245e-15, 181.05), (1000, 3.019e-15, 268.00))
VALID_ALTITUDE_KM = (100.0, 1000.0)   # both models: below, no orbit lasts; above, drag is negligible
_BASES = np.array([row[0] for row in EXPONENTIAL_TABLE], float)
_DENSITIES = np.array([row[1] for row in EXPONENTIAL_TABLE])
_SCALES = np.array([row[2] for row in EXPONENTIAL_TABLE])


def exponential_density(altitude_km) -> np.ndarray:
    """rho = rho0 exp(-(h - h0) / H) of the table row with the largest h0 <= h [kg/m^3], h the
    geodetic height [km] (an array or a number)."""
    h = np.asarray(altitude_km, float)
    row = np.clip(np.searchsorted(_BASES, h, side="right") - 1, 0, len(_BASES) - 1)
    return _DENSITIES[row] * np.exp(-(h - _BASES[row]) / _SCALES[row])


class MsisDensity:
    """NRLMSIS 2.1 total mass density [kg/m^3] at geodetic points, F10.7 [sfu] and Ap held fixed."""

    def __init__(self, f107: float, ap: float):
        import pymsis

        self._calculate, self.f107, self.ap = pymsis.calculate, f107, ap

    def __call__(self, when, lon_deg, lat_deg, altitude_km) -> np.ndarray:
        """The density at UTC instants `when` (datetime64), geodetic longitudes and latitudes [deg]
        and heights above the WGS-84 ellipsoid [km], all arrays of one length."""
        when = np.atleast_1d(when)
        count = len(when)
        out = self._calculate(when, np.atleast_1d(lon_deg), np.atleast_1d(lat_deg), np.atleast_1d(altitude_km),
                              f107s=np.full(count, self.f107), f107as=np.full(count, self.f107),
                              aps=np.full((count, 7), self.ap))
        return np.asarray(out)[..., 0].reshape(-1)
