"""The sun-synchronous orbit of an altitude and a local time of the ascending node: the
inclination at which J2 turns the mean node at the mean Sun's rate, and the node's right ascension
at the epoch that puts it at the given local solar time (docs/theory/environment.md,
"Sun-synchronous orbits")."""

from __future__ import annotations

import math

import numpy as np

from testbed.orbit.constants import EARTH_RADIUS_M, J2, MU_EARTH_M3_S2
from testbed.orbit.earth_rotation import gcrs_to_itrs
from testbed.orbit.sun import sun_state
from testbed.orbit.time_scales import SECONDS_PER_DAY, Epoch

TROPICAL_YEAR_DAYS = 365.2422
# the mean Sun's rate in right ascension [rad/s]: one turn per tropical year
SUN_MEAN_RATE_RAD_S = 2.0 * math.pi / (TROPICAL_YEAR_DAYS * SECONDS_PER_DAY)


def sun_synchronous_cos_inclination(a: float, e: float = 0.0) -> float:
    """cos i of the orbit of semi-major axis a [m] and eccentricity e whose first-order J2 node
    rate -(3/2) n J2 (R/p)^2 cos i (Vallado, *Fundamentals of Astrodynamics*, the
    secular J2 node rate; n = sqrt(mu/a^3), p = a (1 - e^2)) is the
    mean Sun's rate: cos i = -(2/3) Omega' a^(7/2) (1 - e^2)^2 / (J2 R^2 sqrt(mu)). A value
    below -1 means no orbit of that size is sun-synchronous (a > 12 352 km for e = 0)."""
    return (-2.0 / 3.0 * SUN_MEAN_RATE_RAD_S * a**3.5 * (1.0 - e * e) ** 2
            / (J2 * EARTH_RADIUS_M**2 * math.sqrt(MU_EARTH_M3_S2)))


def osculating_inclination(a: float, e: float, true_anomaly: float, arg_latitude: float) -> float:
    """The inclination i [rad] to give the osculating elements at t = 0 (semi-major axis a [m],
    eccentricity e, true anomaly and argument of latitude u = argp + nu [rad]) so that the
    orbit's mean elements are sun-synchronous: Ω' = -(3/2) n̄ J2 (R/p̄)² cos ī with n̄ =
    sqrt(mu/ā³) (1 + (3/4) J2 (R/p̄)² sqrt(1 - e²) (2 - 3 sin² ī)) (Brouwer's mean motion), where
    the mean ā and ī differ from the osculating values by J2's short-period terms, to first order:
    the energy v²/2 - mu/r + mu J2 R² P2(sin φ)/r³ is conserved, so 1/ā = 1/a - 2 J2 R² P2(sin φ0)/r0³
    + 2 J2 R² <P2> / (a³ (1 - e²)^(3/2)), <P2> = (3/4) sin² i - 1/2 over a turn (sin φ = sin i sin u);
    and i - ī = (3/8) J2 (R/p)² sin 2i cos 2u (Kozai 1959). Solved by fixed-point iteration from
    the closed form (docs/theory/environment.md, "Sun-synchronous orbits"). ValueError when no
    inclination makes the mean node turn as fast as the Sun (the orbit is too large)."""
    r0 = a * (1.0 - e * e) / (1.0 + e * math.cos(true_anomaly))
    mean_i = math.acos(max(-1.0, sun_synchronous_cos_inclination(a, e)))
    for _ in range(50):
        s2 = math.sin(mean_i) ** 2
        inverse = (1.0 / a - 2.0 * J2 * EARTH_RADIUS_M**2 * (1.5 * s2 * math.sin(arg_latitude) ** 2 - 0.5) / r0**3
                   + 2.0 * J2 * EARTH_RADIUS_M**2 * (0.75 * s2 - 0.5) / (a**3 * (1.0 - e * e) ** 1.5))
        k = J2 * (EARTH_RADIUS_M * inverse / (1.0 - e * e)) ** 2
        n_bar = math.sqrt(MU_EARTH_M3_S2 * inverse**3) * (1.0 + 0.75 * k * math.sqrt(1.0 - e * e) * (2.0 - 3.0 * s2))
        cos_i = -SUN_MEAN_RATE_RAD_S / (1.5 * n_bar * k)
        if cos_i < -1.0:
            raise ValueError(f"no orbit this large is sun-synchronous: J2 turns its node slower than the Sun "
                             f"at any inclination (cos i would be {cos_i:.4g})")
        previous, mean_i = mean_i, math.acos(cos_i)
        if abs(mean_i - previous) < 1e-15:
            break
    return mean_i + 0.375 * k * math.sin(2.0 * mean_i) * math.cos(2.0 * arg_latitude)


def hours_of_day(jd1, jd2) -> float:
    """The hours since midnight [h] of a two-part Julian date (days begin at .5)."""
    return 24.0 * ((float(jd1) - 0.5) % 1.0 + float(jd2)) % 24.0


def node_right_ascension(epoch: Epoch, local_time_h: float, solar_time: str = "mean") -> float:
    """The ascending node's right ascension [rad, in [0, 2 pi), GCRS] at the epoch (run time 0)
    that puts it at local solar time `local_time_h` [h].

    mean: local mean time is UT1 plus the longitude (15 deg/h), so the node lies at longitude
    15 (LT - UT1) in the ITRS, turned into the GCRS by the Earth's orientation (erfa); this
    local time stays fixed as the node tracks the mean Sun. apparent: the hour angle from the
    true Sun, RA = RA_sun + 15 (LT - 12) (the Sun from erfa.epv00); it differs from the mean
    by the equation of time (up to 16 min, 4 deg) and swings with it over the year."""
    if solar_time == "apparent":
        sun, _ = sun_state(epoch, 0.0)
        angle = math.atan2(sun[1], sun[0]) + math.radians(15.0 * (local_time_h - 12.0))
    else:
        longitude = math.radians(15.0 * (local_time_h - hours_of_day(*epoch.ut1(0.0))))
        node = gcrs_to_itrs(epoch, 0.0)[0].T @ np.array([math.cos(longitude), math.sin(longitude), 0.0])
        angle = math.atan2(node[1], node[0])
    return angle % (2.0 * math.pi)


def parse_local_time(text: str) -> float:
    """Hours [h] of "HH:MM" or "HH:MM:SS" (0 <= HH < 24); ValueError with the reason otherwise."""
    parts = str(text).strip().split(":")
    if len(parts) not in (2, 3) or not all(p.strip().replace(".", "", 1).isdigit() for p in parts):
        raise ValueError(f'is not a time of day "HH:MM" or "HH:MM:SS": "{text}"')
    hours, minutes, seconds = (float(p) for p in parts + ["0"] * (3 - len(parts)))
    if not (hours < 24 and minutes < 60 and seconds < 60):
        raise ValueError(f'is not a time of day (hours < 24, minutes and seconds < 60): "{text}"')
    return hours + minutes / 60.0 + seconds / 3600.0
