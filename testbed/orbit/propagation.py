"""The orbit as a function of time: states on a fixed grid of `step_s`, from RK4 steps of
two-body + J2 gravity or from SGP4 (a TLE), and a cubic Hermite interpolation between the two
grid states around any time asked for. The grid depends on nothing but the orbit, so every
reader (the environment, a guidance law) sees the same trajectory at any rate it runs at."""

from __future__ import annotations

import numpy as np

from testbed.orbit.earth_rotation import teme_to_gcrs
from testbed.orbit.gravity import acceleration


class GravityIntegrator:
    """Two-body (+ J2) motion from (r0, v0), advanced by classical RK4 steps on plain floats."""

    def __init__(self, r0, v0, j2: bool = True):
        self.start = tuple(map(float, r0)) + tuple(map(float, v0))
        self.j2 = None if j2 else 0.0

    def _f(self, s):
        ax, ay, az = acceleration(s[0], s[1], s[2]) if self.j2 is None else acceleration(s[0], s[1], s[2], 0.0)
        return (s[3], s[4], s[5], ax, ay, az)

    def states(self, step: float):
        """(r, v) at t = 0, step, 2 step, ... (a generator)."""
        s = self.start
        h, f = step, self._f
        while True:
            yield s
            k1 = f(s)
            k2 = f([a + h / 2 * b for a, b in zip(s, k1)])
            k3 = f([a + h / 2 * b for a, b in zip(s, k2)])
            k4 = f([a + h * b for a, b in zip(s, k3)])
            s = tuple(a + h / 6 * (b + 2 * c + 2 * d + e) for a, b, c, d, e in zip(s, k1, k2, k3, k4))


class Sgp4Source:
    """States of a TLE by SGP4 (the `sgp4` package) from the run's epoch (a two-part UTC date,
    testbed.orbit.time_scales.Epoch), turned from SGP4's TEME into the GCRS (earth_rotation.py)."""

    def __init__(self, satrec, epoch):
        self.satrec, self.epoch = satrec, epoch

    def states(self, step: float):
        k = 0
        while True:
            seconds = k * step
            day = seconds / 86400.0
            error, r, v = self.satrec.sgp4(self.epoch.utc[0], self.epoch.utc[1] + day)
            if error:
                raise ValueError(f"SGP4 error {error} at t = {seconds:g} s (the orbit decayed or diverged)")
            to_gcrs = 1e3 * teme_to_gcrs(self.epoch, seconds)
            yield tuple(to_gcrs @ r) + tuple(to_gcrs @ v)
            k += 1


class Orbit:
    """r(t) [m], v(t) [m/s] in ECI for any t >= 0 [s]: the grid states of `source` every `step`
    seconds, a cubic Hermite interpolation in position (and its derivative for velocity)
    between the two around t. Times may go back (the grid restarts from t = 0)."""

    def __init__(self, source, step: float):
        self.source, self.step = source, float(step)
        self._restart()

    def _restart(self):
        self._states = self.source.states(self.step)
        self._k = 0
        self._a = next(self._states)
        self._b = next(self._states)

    def state(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(r, v) at t: the Hermite cubic p(s) = h00 r0 + h10 h v0 + h01 r1 + h11 h v1, s = (t - t0)/h."""
        h = self.step
        k = int(t // h)
        if k < self._k:
            self._restart()
        while self._k < k:
            self._a, self._b = self._b, next(self._states)
            self._k += 1
        s = t / h - k
        a, b = self._a, self._b
        s2, s3 = s * s, s * s * s
        h00, h10, h01, h11 = 2 * s3 - 3 * s2 + 1, s3 - 2 * s2 + s, -2 * s3 + 3 * s2, s3 - s2
        d00, d10, d01, d11 = (6 * s2 - 6 * s) / h, 3 * s2 - 4 * s + 1, (-6 * s2 + 6 * s) / h, 3 * s2 - 2 * s
        r = [h00 * a[i] + h10 * h * a[i + 3] + h01 * b[i] + h11 * h * b[i + 3] for i in range(3)]
        v = [d00 * a[i] + d10 * a[i + 3] + d01 * b[i] + d11 * b[i + 3] for i in range(3)]
        return np.array(r), np.array(v)
