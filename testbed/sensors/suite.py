"""Sensor `star_tracker_gyro`: a star tracker and a three-axis gyro package on one bus, each at
its own rate (a whole multiple of the sensor period, sim.estimator_period_s).

Keys (recorded as `sensor/<key>`): `tracker_quat` (w, x, y, z) the last attitude sample,
`tracker_stamp` [s] the time it shows (its sample time less the latency), `tracker_new` 1 at a
call that brought a new sample, `tracker_available` 0 inside an outage or an exclusion, and
with an exclusion angle `tracker_excluded`, what blinds it (bits: 1 the Sun, 2 the Earth,
4 the Moon: exclusion.py); `gyro_rate` [rad/s] the last mean rate, `gyro_stamp` [s] the end of
its interval, and `gyro_bias` [rad/s] the package's true bias there (for the trace and the
bias metrics; no estimator reads it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.errors import InputError
from testbed.math.quaternion import quat_conj, quat_mul, rotation_vector
from testbed.pipeline import require_free_body, stage
from testbed.scenario.schema import whole_multiple
from testbed.sensors.exclusion import Exclusion
from testbed.sensors.gyro_package import GyroPackage, GyroPackageParams
from testbed.sensors.star_tracker import StarTracker, StarTrackerParams, measurement_covariance
from testbed.sensors.suite_worlds import StarTrackerGyroWorlds, batchable

PATH = "pipeline.sensor"


@dataclass(kw_only=True)
class StarTrackerGyroParams:
    star_tracker: StarTrackerParams
    gyro: GyroPackageParams


def sensor_period(ctx) -> float:
    """How often the pipeline calls the sensor [s]."""
    return ctx.sample_period or ctx.control_period


def periods(params: StarTrackerGyroParams, ctx) -> dict:
    """Each instrument's period as a whole number of sensor periods (refused if it is not one),
    and the tracker's latency likewise (0 allowed)."""
    called = sensor_period(ctx)
    multirate = called != ctx.control_period
    unit = "sim.estimator_period_s" if multirate else "sim.control_period_s"
    tracker, gyro = params.star_tracker, params.gyro
    latency = tracker.latency_s
    return {
        "tracker": whole_multiple(tracker.sample_period_s or called, called,
                                  f"{PATH}.star_tracker.sample_period_s", unit),
        "gyro": whole_multiple(gyro.sample_period_s or called, called, f"{PATH}.gyro.sample_period_s", unit),
        "latency": whole_multiple(latency, called, f"{PATH}.star_tracker.latency_s", unit) if latency else 0,
        "called": called}


@stage("sensor", "star_tracker_gyro", StarTrackerGyroParams)
class StarTrackerGyro:
    """A star tracker and a three-axis gyro package, each at its own rate (testbed.sensors)."""

    outputs = ("tracker_quat", "tracker_stamp", "tracker_new", "tracker_available",
               "gyro_rate", "gyro_stamp", "gyro_bias")

    @classmethod
    def design(cls, params: StarTrackerGyroParams) -> dict:
        """What an attitude filter may know of the instruments: the noise model it is tuned to."""
        gyro = params.gyro
        return {"tracker_covariance": measurement_covariance(params.star_tracker).tolist(),
                "angle_random_walk": gyro.angle_random_walk_rad_sqrt_s,
                "rate_random_walk": gyro.rate_random_walk_rad_s_sqrt_s,
                "tracker_latency_s": params.star_tracker.latency_s}

    def __init__(self, params: StarTrackerGyroParams, ctx):
        require_free_body(ctx, "sensor", "star_tracker_gyro")
        every = periods(params, ctx)
        self.called = every["called"]
        self.tracker_every, self.gyro_every, self.delay = every["tracker"], every["gyro"], every["latency"]
        self.tracker = StarTracker(params.star_tracker, self.delay)
        tracker = params.star_tracker
        self.exclusion = None
        given = [field for field in ("sun_exclusion_deg", "earth_exclusion_deg", "moon_exclusion_deg")
                 if getattr(tracker, field) is not None]
        if given:
            if ctx.orbit is None:
                raise InputError(f"pipeline.sensor.star_tracker.{given[0]}", "an exclusion needs the orbit's "
                                 "geometry: add an orbit: block")
            self.exclusion = Exclusion(self.tracker.frame[:, 2], tracker.sun_exclusion_deg,
                                       tracker.earth_exclusion_deg, tracker.moon_exclusion_deg, ctx.orbit,
                                       sensor_period(ctx), ctx.end_time)
        self.gyro = GyroPackage(params.gyro, self.gyro_every * self.called)
        self.seeds = {"star_tracker": params.star_tracker.seed, "gyro": params.gyro.seed}
        self.tick = 0
        self.last_quat = None  # the true attitude at the gyro's last sample
        self.out = {"tracker_quat": np.array([1.0, 0.0, 0.0, 0.0]), "tracker_stamp": np.array([-1.0]),
                    "tracker_new": np.zeros(1), "tracker_available": np.ones(1),
                    "gyro_rate": np.zeros(3), "gyro_stamp": np.array([-1.0]), "gyro_bias": self.gyro.bias.copy()}

    @classmethod
    def batched(cls, stages: list) -> StarTrackerGyroWorlds | None:
        """The sensors of many worlds as one (testbed.sensors.suite_worlds), or None: each its own."""
        return StarTrackerGyroWorlds(stages) if batchable(stages) else None

    def applied(self) -> dict:
        """The noise seeds the instruments draw with (testbed.campaign.applied_values)."""
        return dict(self.seeds)

    def measure(self, t, plant):
        quat = plant.quat()
        out = self.out
        if self.tick % self.gyro_every == 0:
            turn = (plant.omega() * self.gyro.period if self.last_quat is None
                    else rotation_vector(quat_mul(quat_conj(self.last_quat), quat)))
            self.last_quat = quat
            out["gyro_rate"] = self.gyro.sample(turn)
            out["gyro_stamp"] = np.array([t])
            out["gyro_bias"] = self.gyro.bias.copy()
        self.tracker.seen(quat)
        available = self.tracker.available(t)
        if self.exclusion is not None:
            excluded = self.exclusion.cause(t, quat)
            out["tracker_excluded"] = np.array([float(excluded)])
            available = available and not excluded
        fresh = available and self.tick % self.tracker_every == 0
        if fresh:
            out["tracker_quat"] = self.tracker.sample()
            out["tracker_stamp"] = np.array([t - self.delay * self.called])
        out["tracker_new"] = np.array([1.0 if fresh else 0.0])
        out["tracker_available"] = np.array([1.0 if available else 0.0])
        self.tick += 1
        return dict(out)
