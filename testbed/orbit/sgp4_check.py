"""A second route from SGP4's TEME to the GCRS, for checking the run's orbit against SGP4
called directly: the classical equinox-based chain of Vallado et al. (AIAA 2006-6753) that
defines TEME, r_GCRS = (R3(Eq_eq) N P B)ᵀ r_TEME, with the frame bias B, the IAU 1976
precession and IAU 1980 nutation N P (erfa.bp00, erfa.pnm80) and the equation of the equinoxes
(erfa.eqeq94). The run takes the CIO-based IAU 2006/2000A route instead
(testbed/orbit/earth_rotation.py): the two differ by the nutation theories, at most 40 mas
(1.9e-7 rad, measured every 91 days over 1990-2030), 1.3 m at 6800 km."""

from __future__ import annotations

import math

import erfa
import numpy as np


def teme_to_gcrs_by_equinox(epoch, t: float) -> np.ndarray:
    """The matrix (3, 3) taking TEME components to GCRS ones at run time t [s] (module doc)."""
    tt = epoch.tt(t)
    c, s = math.cos(erfa.eqeq94(*tt)), math.sin(erfa.eqeq94(*tt))
    true_to_teme = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    return (true_to_teme @ erfa.pnm80(*tt) @ erfa.bp00(*tt)[0]).T


def sgp4_positions(satrec, epoch, times) -> np.ndarray:
    """SGP4's positions (N, 3) [m] of `satrec` at run times [s] from `epoch`, in the GCRS by the
    equinox route (module doc)."""
    rows = []
    for t in np.asarray(times, float):
        error, r, _ = satrec.sgp4(epoch.utc[0], epoch.utc[1] + t / 86400.0)
        rows.append(teme_to_gcrs_by_equinox(epoch, t) @ (1e3 * np.asarray(r)) if not error else np.full(3, np.nan))
    return np.array(rows).reshape(-1, 3)
