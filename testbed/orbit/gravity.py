"""The Earth's gravity as the orbit feels it: point mass plus the J2 zonal term (Vallado,
*Fundamentals of Astrodynamics*, eq. 8-30), on plain floats (it runs at every RK4 stage)."""

from __future__ import annotations

from testbed.orbit.constants import EARTH_RADIUS_M, J2, MU_EARTH_M3_S2


def acceleration(x: float, y: float, z: float, j2: float = J2, mu: float = MU_EARTH_M3_S2,
                 radius: float = EARTH_RADIUS_M) -> tuple[float, float, float]:
    """ECI acceleration [m/s^2] at (x, y, z) [m]: -mu r / r^3 and
    -(3/2) J2 mu R^2 / r^5 (x (1 - 5 z^2/r^2), y (1 - 5 z^2/r^2), z (3 - 5 z^2/r^2))."""
    r2 = x * x + y * y + z * z
    r = r2 ** 0.5
    kepler = -mu / (r2 * r)
    if not j2:
        return kepler * x, kepler * y, kepler * z
    zz = 5.0 * z * z / r2
    k = -1.5 * j2 * mu * radius * radius / (r2 * r2 * r)
    return (kepler * x + k * x * (1.0 - zz), kepler * y + k * y * (1.0 - zz), kepler * z + k * z * (3.0 - zz))
