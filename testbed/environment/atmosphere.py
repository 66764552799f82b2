"""Atmospheric density: the exponential model of Vallado's Table 8-4 (*Fundamentals of
Astrodynamics*, 4th ed.; a fixed 1976 US Standard / CIRA-72 fit), or NRLMSIS 2.1 (the
`pymsis` package) at fixed solar and geomagnetic indices, so nothing is downloaded."""

from __future__ import annotations

import math

import numpy as np

# base altitude h0 [km], density at h0 [kg/m^3], scale height H [km] (Vallado Table 8-4)
EXPONENTIAL_TABLE = (
    (100, 5.297e-7, 5.877), (110, 9.661e-8, 7.263), (120, 2.438e-8, 9.473), (130, 8.484e-9, 12.636),
    (140, 3.845e-9, 16.149), (150, 2.070e-9, 22.523), (180, 5.464e-10, 29.740), (200, 2.789e-10, 37.105),
    (250, 7.248e-11, 45.546), (300, 2.418e-11, 53.628), (350, 9.518e-12, 53.298), (400, 3.725e-12, 58.515),
    (450, 1.585e-12, 60.828), (500, 6.967e-13, 63.822), (600, 1.454e-13, 71.835), (700, 3.614e-14, 88.667),
    (800, 1.170e-14, 124.64), (900, 5.245e-15, 181.05), (1000, 3.019e-15, 268.00))
VALID_ALTITUDE_KM = (100.0, 1000.0)   # both models: below, no orbit lasts; above, drag is negligible


def exponential_density(altitude_km: float) -> float:
    """rho = rho0 exp(-(h - h0) / H) of the table row with the largest h0 <= h [kg/m^3]."""
    row = EXPONENTIAL_TABLE[0]
    for candidate in EXPONENTIAL_TABLE:
        if candidate[0] <= altitude_km:
            row = candidate
    h0, rho0, scale = row
    return rho0 * math.exp(-(altitude_km - h0) / scale)


class MsisDensity:
    """NRLMSIS 2.1 total mass density at a geodetic point, F10.7 and Ap held fixed."""

    def __init__(self, f107: float, ap: float):
        import pymsis

        self._calculate, self.f107, self.ap = pymsis.calculate, f107, ap

    def __call__(self, when: np.datetime64, lon_deg: float, lat_deg: float, altitude_km: float) -> float:
        out = self._calculate(np.array([when]), lon_deg, lat_deg, altitude_km, [self.f107], [self.f107],
                              [[self.ap] * 7])
        return float(np.asarray(out).reshape(-1)[0])
