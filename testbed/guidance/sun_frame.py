"""The Sun-pointing frame along an orbit: z toward the Sun as the spacecraft sees it (from its
position r, the direction of s - r), y opposite the Sun's apparent orbit normal (the ecliptic
pole, from the Earth's heliocentric motion), x = y × z. It turns about its y axis at the Sun's
apparent rate ω_s = |s × ṡ| / |s|² (2e-7 rad/s), its rate's change (< 1e-14 rad/s²) and the
parallax's daily wobble (< 5e-8 rad/s) left out (docs/theory/environment.md)."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from testbed.math.cross import cross3
from testbed.orbit.sun import sun_state

EPHEMERIS_SPAN_S = 6 * 3600.0   # the Sun's state is refreshed this often and moved along its velocity between


def sun_frame(orbit, epoch):
    """frame(t) -> (q_frame, ω_frame, ω_frame') of the Sun-pointing axes (module doc) along
    `orbit` (a testbed.orbit.propagation.Orbit) from the run's `epoch`; for pointing.HeldAttitude."""
    ephemeris = {"t": None}

    def frame(t):
        if ephemeris["t"] is None or abs(t - ephemeris["t"]) > EPHEMERIS_SPAN_S / 2:
            ephemeris["t"] = t + EPHEMERIS_SPAN_S / 2
            ephemeris["s"], ephemeris["v"] = sun_state(epoch, ephemeris["t"])
        sun = ephemeris["s"] + (t - ephemeris["t"]) * ephemeris["v"]
        normal = cross3(sun, ephemeris["v"])
        rate = math.sqrt(normal @ normal) / float(sun @ sun)
        r, _ = orbit.state(t)
        z = sun - r
        z = z / math.sqrt(z @ z)
        y = z * float(normal @ z) - normal   # -normal, made normal to z
        y = y / math.sqrt(y @ y)
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, np.column_stack([cross3(y, z), y, z]).ravel())
        return quat, np.array([0.0, -rate, 0.0]), np.zeros(3)

    return frame
