"""Sun and Earth exclusion of a star tracker: blinded while the Sun lies within
`sun_exclusion_deg` of the boresight, or the Earth's limb within `earth_exclusion_deg` of it
(the Earth's disc, of angular radius asin(R / |r|) about nadir, grown by that angle). The
directions come from the orbit's geometry: the sensor's own copy of the orbit and the Sun
(testbed.environment.along_orbit) at the tracker's sample instants, and the true attitude."""

from __future__ import annotations

import math

import numpy as np

from testbed.environment.along_orbit import AlongOrbit
from testbed.math.quaternion import quat_conj, quat_rotate
from testbed.orbit.constants import EARTH_RADIUS_M

SUN, EARTH = 1, 2   # the causes, as bits of the `tracker_excluded` code


def blinded(boresight: np.ndarray, direction: np.ndarray, half_angle_rad: float) -> bool:
    """True when unit `direction` lies within `half_angle_rad` of unit `boresight` (both body axes)."""
    return float(np.dot(boresight, direction)) > np.cos(half_angle_rad)


class Exclusion:
    """Which bright bodies blind a tracker of boresight `boresight` (unit, body axes) at a time:
    `cause(t, quat)` -> 0, or SUN | EARTH bits, for the true attitude quat (body to ECI)."""

    def __init__(self, boresight, sun_deg, earth_deg, orbit_params, period: float, end_time: float):
        self.boresight = np.asarray(boresight, float)
        self.sun = None if sun_deg is None else math.radians(sun_deg)
        self.earth = None if earth_deg is None else math.radians(earth_deg)
        last = int(min(end_time, 1e9) / period) + 1
        self.along = AlongOrbit(orbit_params.propagator(), orbit_params.epoch(), period, last, sun=self.sun is not None)

    def cause(self, t: float, quat) -> int:
        here = self.along.at(t)
        to_body = quat_conj(quat)
        code = 0
        if self.sun is not None:
            to_sun = here["sun"] - here["r"]
            if blinded(self.boresight, quat_rotate(to_body, to_sun / np.linalg.norm(to_sun)), self.sun):
                code |= SUN
        if self.earth is not None:
            distance = float(np.linalg.norm(here["r"]))
            limb = math.asin(min(1.0, EARTH_RADIUS_M / distance))
            if blinded(self.boresight, quat_rotate(to_body, -here["r"] / distance), limb + self.earth):
                code |= EARTH
        return code
