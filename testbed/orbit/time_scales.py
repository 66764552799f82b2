"""The run's clock against the time scales (pyerfa, the IAU's SOFA routines): t = 0 is a UTC
instant kept as a two-part Julian date (day, fraction), so no precision is lost in one double;
the run's seconds are SI seconds on TAI. TT = TAI + 32.184 s; UT1 is taken as UTC (no IERS
table is read, so nothing is downloaded: |UT1 - UTC| < 0.9 s, docs/theory/environment.md).
Outside the years its leap-second table knows (before 1960, after it expires) SOFA warns of a
"dubious year" and goes on with the nearest offset: that is the model here, so the warning is
kept quiet."""

from __future__ import annotations

import warnings

import erfa
import numpy as np

SECONDS_PER_DAY = 86400.0


class Epoch:
    """The UTC instant of t = 0 as (jd1, jd2), and the TT and UT1 dates of run times t [s]."""

    def __init__(self, utc1: float, utc2: float):
        self.utc = (float(utc1), float(utc2))
        self._tai = _quiet(erfa.utctai, *self.utc)

    def tai(self, t) -> tuple[np.ndarray, np.ndarray]:
        """Two-part TAI Julian date of run times t [s]."""
        return self._tai[0], self._tai[1] + np.asarray(t, float) / SECONDS_PER_DAY

    def tt(self, t) -> tuple[np.ndarray, np.ndarray]:
        """Two-part TT Julian date of run times t [s] (erfa.taitt)."""
        return erfa.taitt(*self.tai(t))

    def ut1(self, t) -> tuple[np.ndarray, np.ndarray]:
        """Two-part UT1 Julian date of run times t [s], taken as UTC (erfa.taiutc)."""
        return _quiet(erfa.taiutc, *self.tai(t))

    def utc_datetime64(self, t) -> np.ndarray:
        """UTC of run times t [s] as numpy datetime64[us] (what pymsis and ppigrf take)."""
        jd1, jd2 = self.ut1(t)
        days = (np.asarray(jd1) - 2440587.5) + np.asarray(jd2)  # since 1970-01-01 00:00 UTC
        return np.datetime64("1970-01-01T00:00:00", "us") + np.round(days * 86400e6).astype("timedelta64[us]")


def utc_parts(year: int, month: int, day: int, hour: int, minute: int, second: float) -> tuple[float, float]:
    """Two-part UTC Julian date of a calendar date and time (erfa.dtf2d, leap seconds known)."""
    return tuple(map(float, _quiet(erfa.dtf2d, "UTC", year, month, day, hour, minute, second)))


def _quiet(function, *args):
    """function(*args) with SOFA's "dubious year" warning kept quiet (module doc)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", erfa.ErfaWarning)
        return function(*args)
