"""A point fixed on the Earth, given by its WGS-84 geodetic latitude, longitude and height: its
Earth-fixed position (erfa.gd2gc), and its position, velocity and acceleration in the GCRS (the
testbed's ECI) as the Earth turns it (testbed.orbit.earth_rotation), with its local vertical."""

from __future__ import annotations

import math

import erfa
import numpy as np

from testbed.orbit.constants import EARTH_RATE_RAD_S
from testbed.orbit.earth_rotation import about_z
from testbed.orbit.time_scales import Epoch

WGS84 = 1                         # erfa's ellipsoid number
PRECESSION_SPAN_S = 6 * 3600.0    # the celestial-to-intermediate matrix is refreshed this often


class GroundSite:
    """The site at geodetic `latitude`, `longitude` [rad] and `height` [m] above the WGS-84
    ellipsoid, seen from the GCRS from the run's `epoch`."""

    def __init__(self, latitude: float, longitude: float, height: float, epoch: Epoch):
        self.fixed = np.asarray(erfa.gd2gc(WGS84, longitude, latitude, height), float)  # ITRS [m]
        # the ellipsoid's normal: the local vertical, ITRS
        self.up_fixed = np.array([math.cos(latitude) * math.cos(longitude),
                                  math.cos(latitude) * math.sin(longitude), math.sin(latitude)])
        self.epoch = epoch
        self._block = (None, None)

    def _to_intermediate(self, t: float) -> np.ndarray:
        """C, GCRS to the celestial intermediate frame (erfa.c2i06a), taken at the middle of the
        6 h block holding t (it moves < 1e-7 rad in 3 h: precession and nutation)."""
        block = math.floor(t / PRECESSION_SPAN_S)
        if self._block[0] != block:
            middle = (block + 0.5) * PRECESSION_SPAN_S
            self._block = (block, erfa.c2i06a(*self.epoch.tt(middle)))
        return self._block[1]

    def state(self, t: float):
        """(r [m], v [m/s], a [m/s^2], up (unit)) of the site at run time t [s], GCRS axes:
        r = Cᵀ R3(ERA)ᵀ r_ITRS, v = ω × r, a = ω × v, ω = ω_E Cᵀ e_z (the Earth's rate about the
        intermediate pole; polar motion left out, as in earth_rotation.py)."""
        c = self._to_intermediate(t)
        to_gcrs = c.T @ about_z(erfa.era00(*self.epoch.ut1(t))).T
        rate = EARTH_RATE_RAD_S * c[2]
        r = to_gcrs @ self.fixed
        v = np.cross(rate, r)
        return r, v, np.cross(rate, v), to_gcrs @ self.up_fixed


def elevation(site_position, up, spacecraft_position) -> float:
    """The spacecraft's elevation above the site's horizon [rad]: asin(up · (r_sc - r_site) / |r_sc - r_site|)."""
    line = np.asarray(spacecraft_position, float) - site_position
    return math.asin(max(-1.0, min(1.0, float(up @ line) / math.sqrt(line @ line))))
