"""What the environment needs that depends on the orbit and the time but not on the attitude
(the position and velocity, the Sun, the Moon, the field in ECI, the density, the Earth's axis),
evaluated for a block of update instants at once by the libraries' vectorised calls and read
one instant at a time: their per-call cost is paid once a block (docs/theory/environment.md)."""

from __future__ import annotations

import erfa
import numpy as np

from testbed.environment.atmosphere import exponential_density
from testbed.environment.magnetic_field import field_itrs
from testbed.orbit.earth_rotation import gcrs_to_itrs
from testbed.orbit.moon import moon_positions
from testbed.orbit.sun import sun_positions

BLOCK_SPAN_S = 6 * 3600.0   # the precession-nutation and the Sun's motion are taken at a block's middle
BLOCK_INSTANTS = 2048


class AlongOrbit:
    """Rows of values at the instants k `period` [s], k = 0 .. last: `at(t)` for t on that grid.

    Each row: r, v [m, m/s] (ECI = GCRS), and as asked for: `sun`, `moon` [m, GCRS], `field` [T, GCRS]
    (`field_model` igrf | dipole), `density` [kg/m^3] (`density_model` a MsisDensity, or
    "exponential") at the geodetic point of r, `pole` (the ITRS z axis in GCRS)."""

    def __init__(self, orbit, epoch, period: float, last: int, *, sun: bool, moon: bool = False, field_model=None,
                 density_model=None):
        self.orbit, self.epoch, self.period, self.last = orbit, epoch, period, last
        self.sun, self.moon, self.field_model, self.density_model = sun, moon, field_model, density_model
        self.earth_fixed = field_model is not None or density_model is not None
        self.size = max(1, min(BLOCK_INSTANTS, int(BLOCK_SPAN_S // period)))
        self._first, self._rows = None, None

    def at(self, t: float) -> dict[str, np.ndarray]:
        """The row of the grid instant nearest t [s]."""
        k = int(round(t / self.period))
        if self._first is None or not self._first <= k < self._first + len(self._rows["r"]):
            # blocks on a fixed grid of instants, so a row is the same whatever the run's length
            first = k - k % self.size
            self._rows, self._first = self._block(first), first
        i = k - self._first
        return {name: values[i] for name, values in self._rows.items()}

    def _block(self, first: int) -> dict[str, np.ndarray]:
        count = max(1, min(self.size, self.last - first + 1))
        # the slow quantities are taken at the middle of the whole block, even where the run ends
        # inside it: a run's rows do not depend on its length
        block_times = (first + np.arange(self.size)) * self.period
        times = block_times[:count]
        states = [self.orbit.state(t) for t in times]
        r = np.array([s[0] for s in states])
        rows = {"r": r, "v": np.array([s[1] for s in states])}
        if self.sun:
            rows["sun"] = sun_positions(self.epoch, block_times)[:count]
        if self.moon:
            rows["moon"] = moon_positions(self.epoch, times)
        if not self.earth_fixed:
            return rows
        to_itrs = gcrs_to_itrs(self.epoch, block_times)[:count]
        rows["pole"] = to_itrs[:, 2, :]
        r_itrs = np.einsum("nij,nj->ni", to_itrs, r)
        if self.field_model is not None:
            middle = self.epoch.utc_datetime64(0.5 * (block_times[0] + block_times[-1]))
            rows["field"] = np.einsum("nji,nj->ni", to_itrs, field_itrs(r_itrs, middle, self.field_model))
        if self.density_model is not None:
            longitude, latitude, height = erfa.gc2gd(1, r_itrs)   # 1: WGS-84
            if self.density_model == "exponential":
                rows["density"] = exponential_density(height / 1e3)
            else:
                rows["density"] = self.density_model(self.epoch.utc_datetime64(times), np.degrees(longitude),
                                                     np.degrees(latitude), height / 1e3)
        return rows
