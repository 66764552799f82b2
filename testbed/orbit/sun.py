"""The Sun's geocentric position from the IAU's Earth ephemeris (pyerfa's epv00, VSOP2000
fitted, a few km) in the GCRS, and the Earth's cylindrical shadow."""

from __future__ import annotations

import erfa
import numpy as np

from testbed.orbit.constants import AU_M, EARTH_RADIUS_M
from testbed.orbit.time_scales import SECONDS_PER_DAY, Epoch


def sun_state(epoch: Epoch, t: float) -> tuple[np.ndarray, np.ndarray]:
    """Geometric geocentric Sun position [m] and velocity [m/s], GCRS axes, at run time t [s]:
    minus the Earth's heliocentric position and velocity of erfa.epv00."""
    heliocentric, _ = erfa.epv00(*epoch.tt(t))
    return (-AU_M * np.asarray(heliocentric["p"], float),
            -AU_M / SECONDS_PER_DAY * np.asarray(heliocentric["v"], float))


def sun_positions(epoch: Epoch, times) -> np.ndarray:
    """Geometric geocentric Sun positions (N, 3) [m], GCRS axes, at run times [s]: `sun_state`
    at the middle time, moved along its velocity (over half a span of 6 h the path's curvature,
    0.5", lies along the line of sight: the direction is within 0.01"; aberration, 20", is left out)."""
    times = np.atleast_1d(np.asarray(times, float))
    middle = 0.5 * (times[0] + times[-1])
    position, velocity = sun_state(epoch, middle)
    return position + (times - middle)[:, None] * velocity


def in_cylindrical_shadow(r, sun, radius: float = EARTH_RADIUS_M) -> bool:
    """True when the position r [m] is behind the Earth (r . s < 0, s the unit Sun direction)
    and within `radius` of the Earth-Sun line: |r - (r . s) s| < R."""
    r = np.asarray(r, float)
    s = np.asarray(sun, float) / np.linalg.norm(sun)
    along = float(r @ s)
    return along < 0.0 and float(np.linalg.norm(r - along * s)) < radius
