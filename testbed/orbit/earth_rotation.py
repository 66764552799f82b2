"""The Earth's orientation (pyerfa, IAU 2006/2000A): the rotation from the GCRS (the testbed's
ECI) to the terrestrial frame ITRS, polar motion neglected (< 0.5", no IERS table), and the
rotation from SGP4's TEME to the GCRS (Vallado et al., AIAA 2006-6753: TEME to the
pseudo-Earth-fixed frame by GMST 1982, then to the GCRS through the ITRS)."""

from __future__ import annotations

import erfa
import numpy as np

from testbed.orbit.time_scales import Epoch


def about_z(angle) -> np.ndarray:
    """Frame rotations R3(angle) [rad], (N, 3, 3): the components in axes turned by +angle about z."""
    c, s = np.cos(angle), np.sin(angle)
    m = np.zeros(np.shape(angle) + (3, 3))
    m[..., 0, 0], m[..., 0, 1], m[..., 1, 0], m[..., 1, 1], m[..., 2, 2] = c, s, -s, c, 1.0
    return m


def gcrs_to_itrs(epoch: Epoch, times) -> np.ndarray:
    """Matrices (N, 3, 3) taking GCRS components to ITRS ones at run times [s]:
    R3(ERA(UT1)) C(X, Y, s), the celestial-to-intermediate matrix C (erfa.c2i06a) taken once at
    the middle time: over a span of a day it moves by < 1e-6 rad (precession and nutation)."""
    times = np.atleast_1d(np.asarray(times, float))
    middle = 0.5 * (times[0] + times[-1])
    to_cirs = erfa.c2i06a(*epoch.tt(middle))
    return about_z(erfa.era00(*epoch.ut1(times))) @ to_cirs


def teme_to_gcrs(epoch: Epoch, t: float) -> np.ndarray:
    """The matrix (3, 3) taking TEME components to GCRS ones at run time t [s]: C^T R3(GMST82),
    with C the GCRS-to-ITRS matrix (the rotation rates of the two cancel to ~1e-11 rad/s, so it
    turns velocities too)."""
    return gcrs_to_itrs(epoch, t)[0].T @ about_z(erfa.gmst82(*epoch.ut1(t)))
