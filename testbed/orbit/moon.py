"""The Moon's geocentric position from pyerfa's moon98 (Meeus, *Astronomical Algorithms*,
2nd ed. 1998, ch. 47, in full but for the 0.7" light-time term of the mean longitude; against
ELP/MPP02 over 1950-2100: 2.9" rms and 18.3" at worst in direction, 6.1 km rms in distance)
in the GCRS, the testbed's ECI."""

from __future__ import annotations

import erfa
import numpy as np

from testbed.orbit.constants import AU_M


def moon_positions(epoch, times) -> np.ndarray:
    """Geometric geocentric Moon positions (N, 3) [m], GCRS axes, at run times [s] (erfa.moon98
    at each instant's TT: the Moon moves 0.5" a second, so UT would be 30" off)."""
    times = np.atleast_1d(np.asarray(times, float))
    return AU_M * np.asarray(erfa.moon98(*epoch.tt(times))["p"], float).reshape(-1, 3)
