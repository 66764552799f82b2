"""Estimator `mekf`: the MEKF of testbed.mekf.filter on a star tracker and a gyro package.

It propagates at each new gyro sample (over the time since its last state) and updates at each
new tracker sample. With a tracker latency L (published by the sensor) the filter itself runs L
behind, at the time the tracker's samples show, keeping the gyro samples since; what it reports
is its state carried forward through them to the latest gyro sample (the usual treatment of a
known, fixed delay: the report's covariance holds the gyro noise over L). It is tuned to the
sensor's published noise model. The first fix: `tracker` starts from the first tracker sample
(a coarse fix of covariance initial_attitude_sigma_deg), `scenario` from the scenario's initial
attitude turned by initial_attitude_error_deg; before a tracker fix it reports the scenario's
initial attitude. A filter that held its attitude 3-sigma within `coast_bound` at an update
and then coasts past it without a fix ends the run (MethodFailed): its error model no longer holds.

Keys: `quat`, `omega` (gyro rate less the bias estimate), `bias` [rad/s], `attitude_sigma3`
and `bias_sigma3` (3 √diag P), `covariance` (P row by row, 36), `innovation` [rad] and `nis`
(zᵀ S⁻¹ z) of the last update, `updated` (1 at an update).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Literal

import numpy as np

from testbed.errors import InputError
from testbed.math.quaternion import quat_from_rotation_vector, quat_mul
from testbed.mekf.filter import Mekf
from testbed.mekf.worlds import MekfWorlds, batchable
from testbed.pipeline import MethodFailed, stage
from testbed.scenario.schema import join, param

PATH = "pipeline.estimator"
DEG_H = np.pi / 180.0 / 3600.0  # 1 deg/h [rad/s]
NEEDS = ("tracker_covariance", "angle_random_walk", "rate_random_walk")


def coast_bound(tracker_covariance) -> np.ndarray:
    """Per body axis, the attitude 3-sigma [rad] up to which the MEKF's first-order error model
    holds: composing rotations neglects 1/2 |d_theta|^2 (the second-order term), which stays
    below the tracker's own noise sigma_m, the correction the update is built for, while
    1/2 (3 sigma)^2 <= sigma_m, i.e. 3 sigma <= sqrt(2 sigma_m) (docs/theory/attitude_determination.md
    "When the filter has coasted too long"). sigma_m per axis from R's diagonal [rad^2]."""
    return np.sqrt(2.0 * np.sqrt(np.diag(np.asarray(tracker_covariance, float))))


@dataclass(kw_only=True)
class MekfParams:
    first_fix: Literal["tracker", "scenario"] = param("tracker", doc="start from the first tracker sample, or the scenario's attitude")
    initial_attitude_sigma_deg: float = param(1.0, gt=0, le=180, doc="1 sigma of the first fix, per axis")
    initial_bias_sigma_deg_h: float = param(10.0, gt=0, le=1e6, doc="1 sigma of the initial bias estimate, per axis")
    initial_covariance: list[list[float]] | None = param(None, length=6, doc="6 x 6 P0 [rad^2, rad^2/s, rad^2/s^2] in place of the sigmas")
    initial_attitude_error_deg: list[float] = param([0.0, 0.0, 0.0], length=3, doc="first_fix scenario: rotation vector off the true start")
    initial_bias_rad_s: list[float] = param([0.0, 0.0, 0.0], length=3, doc="initial bias estimate")
    settle_s: float = param(0.0, ge=0, doc="time after which the metrics count the filter converged")

    def validate(self, path: str) -> None:
        if self.initial_covariance is None:
            return
        field = join(path, "initial_covariance")
        p = np.asarray(self.initial_covariance, float)
        if p.shape != (6, 6):
            raise InputError(field, f"must be 6 x 6, got shape {p.shape}")
        if not np.allclose(p, p.T, rtol=1e-12, atol=0.0):
            raise InputError(field, "must be symmetric")
        if np.min(np.linalg.eigvalsh(p)) <= 0:
            raise InputError(field, f"must be positive definite (smallest eigenvalue {np.min(np.linalg.eigvalsh(p)):.3g})")

    def covariance(self) -> np.ndarray:
        if self.initial_covariance is not None:
            return np.asarray(self.initial_covariance, float)
        return np.diag([np.radians(self.initial_attitude_sigma_deg) ** 2] * 3
                       + [(self.initial_bias_sigma_deg_h * DEG_H) ** 2] * 3)


@stage("estimator", "mekf", MekfParams)
class MekfEstimator:
    """Multiplicative extended Kalman filter: attitude and gyro biases from star_tracker_gyro."""

    outputs = ("quat", "omega", "bias", "attitude_sigma3", "bias_sigma3", "covariance", "innovation", "nis",
               "updated")

    def __init__(self, params: MekfParams, ctx):
        sensor = ctx.stages["sensor"]
        missing = [key for key in NEEDS if key not in sensor.design]
        if missing:
            raise InputError(f"{PATH}.type", f"mekf needs a sensor that publishes a star tracker's and a gyro "
                             f"package's noise (e.g. star_tracker_gyro), got sensor {sensor.type!r}")
        self.noise = np.asarray(sensor.design["tracker_covariance"], float)
        start = np.asarray(ctx.initial.quat, float)
        if params.first_fix == "scenario":
            start = quat_mul(start, quat_from_rotation_vector(np.radians(params.initial_attitude_error_deg)))
        self.filter = Mekf(start, params.initial_bias_rad_s, params.covariance(),
                           sensor.design["angle_random_walk"], sensor.design["rate_random_walk"])
        self.fixed = params.first_fix == "scenario"
        self.latency = float(sensor.design.get("tracker_latency_s", 0.0))
        self.time = 0.0  # the time the filter's state is at: the tracker's, now - latency
        self.pending = deque()  # (stamp, rate) of the gyro samples after self.time
        self.innovation, self.nis = np.zeros(3), np.zeros(1)
        self.statistics = {"settle_s": params.settle_s}
        self.coast_bound = coast_bound(self.noise)
        self.last_fix: float | None = None   # when the last update came, if the filter then held its bound

    @classmethod
    def batched(cls, stages: list) -> MekfWorlds | None:
        """The estimators of many worlds as one (testbed.mekf.worlds), or None: each its own."""
        return MekfWorlds(stages) if batchable(stages) else None

    def _advance(self, until: float) -> None:
        """Propagate the filter through the pending gyro samples up to time `until`."""
        f = self.filter
        while self.pending and self.pending[0][0] <= until + 1e-9:
            stamp, rate = self.pending.popleft()
            if stamp > self.time:
                f.propagate(rate, stamp - self.time)
                self.time = stamp

    def _predicted(self) -> Mekf:
        """The filter carried forward through the gyro samples newer than its state (latency)."""
        if not self.pending:
            return self.filter
        f = self.filter
        ahead, time = Mekf(f.quat, f.bias, f.covariance, f.arw, f.rrw), self.time
        for stamp, rate in self.pending:
            ahead.propagate(rate, stamp - time)
            time = stamp
        return ahead

    def _check_coast(self, t: float, updated: float, sigma3) -> None:
        """End the run (MethodFailed) when the filter, having held its attitude 3-sigma within
        `coast_bound` at its last update, has coasted without a fix past it."""
        if updated:
            self.last_fix = t if np.all(sigma3 <= self.coast_bound) else None
        elif self.last_fix is not None and np.any(sigma3 > self.coast_bound):
            axis = int(np.argmax(sigma3 / self.coast_bound))
            raise MethodFailed(
                f"no star tracker fix for {t - self.last_fix:.6g} s: the attitude 3-sigma about body axis "
                f"{'xyz'[axis]} reached {np.degrees(sigma3[axis]):.3g} deg, past the "
                f"{np.degrees(self.coast_bound[axis]):.3g} deg the filter's first-order error model holds "
                f"to (sqrt(2 sigma_tracker), docs/theory/attitude_determination.md)")

    def estimate(self, t, measurement, command):
        f = self.filter
        updated = 0.0
        stamp = float(measurement["gyro_stamp"][0])
        if self.fixed and stamp > self.time and (not self.pending or stamp > self.pending[-1][0]):
            self.pending.append((stamp, np.array(measurement["gyro_rate"], float)))
        if measurement["tracker_new"][0]:
            seen = float(measurement["tracker_stamp"][0])
            if not self.fixed:
                f.quat = np.array(measurement["tracker_quat"], float)
                self.time, self.fixed = seen, True
            else:
                self._advance(seen)
                self.innovation = f.innovation(measurement["tracker_quat"])
                self.nis = np.array([f.update(self.innovation, self.noise)])
                updated = 1.0
        self._advance(t - self.latency)  # no sample (an outage): the filter keeps up all the same
        now = self._predicted()
        p = now.covariance
        sigma3 = 3.0 * np.sqrt(np.diag(p))
        self._check_coast(t, updated, sigma3[:3])
        return {"quat": now.quat, "omega": measurement["gyro_rate"] - now.bias, "bias": now.bias,
                "attitude_sigma3": sigma3[:3], "bias_sigma3": sigma3[3:],
                "covariance": p.ravel(), "innovation": self.innovation, "nis": self.nis,
                "updated": np.array([updated])}
