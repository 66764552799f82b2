"""Sun, Earth and Moon exclusion of a star tracker: blinded while the Sun lies within
`sun_exclusion_deg` of the boresight, the Earth's limb within `earth_exclusion_deg` of it
(the Earth's disc, of angular radius asin(R / |r|) about nadir, grown by that angle), or the
Moon's centre within `moon_exclusion_deg` of it. The directions come from the orbit's
geometry: the sensor's own copy of the orbit, the Sun and the Moon
(testbed.environment.along_orbit) at the tracker's sample instants, seen from the spacecraft
(the Moon's parallax, up to 1.1 deg in LEO, is in), and the true attitude."""

from __future__ import annotations

import math

import numpy as np

from testbed.environment.along_orbit import AlongOrbit
from testbed.math.quaternion import quat_conj, quat_rotate
from testbed.orbit.constants import EARTH_RADIUS_M

SUN, EARTH, MOON = 1, 2, 4   # the causes, as bits of the `tracker_excluded` code


def blinded(boresight: np.ndarray, direction: np.ndarray, half_angle_rad: float) -> bool:
    """True when unit `direction` lies within `half_angle_rad` of unit `boresight` (both body axes)."""
    return float(np.dot(boresight, direction)) > np.cos(half_angle_rad)


def _radians(degrees):
    return None if degrees is None else math.radians(degrees)


class Exclusion:
    """Which bright bodies blind a tracker of boresight `boresight` (unit, body axes) at a time:
    `cause(t, quat)` -> 0, or SUN | EARTH | MOON bits, for the true attitude quat (body to ECI).
    An angle [deg] of None leaves that body out."""

    def __init__(self, boresight, sun_deg, earth_deg, moon_deg, orbit_params, period: float, end_time: float):
        self.boresight = np.asarray(boresight, float)
        self.sun, self.earth, self.moon = _radians(sun_deg), _radians(earth_deg), _radians(moon_deg)
        last = int(min(end_time, 1e9) / period) + 1
        self.along = AlongOrbit(orbit_params.propagator(), orbit_params.epoch(), period, last,
                                sun=self.sun is not None, moon=self.moon is not None)

    def cause(self, t: float, quat) -> int:
        here = self.along.at(t)
        to_body = quat_conj(quat)
        code = 0
        for bit, name, angle in ((SUN, "sun", self.sun), (MOON, "moon", self.moon)):
            if angle is not None:
                towards = here[name] - here["r"]
                if blinded(self.boresight, quat_rotate(to_body, towards / np.linalg.norm(towards)), angle):
                    code |= bit
        if self.earth is not None:
            distance = float(np.linalg.norm(here["r"]))
            limb = math.asin(min(1.0, EARTH_RADIUS_M / distance))
            if blinded(self.boresight, quat_rotate(to_body, -here["r"] / distance), limb + self.earth):
                code |= EARTH
        return code
