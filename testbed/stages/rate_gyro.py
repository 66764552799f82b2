"""Single-axis rate gyro: y = p . w + bias + noise, quantised, sampled at its own period.

The only measurement of the Lebedev problem (Lebedev 1976, eq. 1.1). The sensing axis p is a
unit vector in body axes; a non-unit axis is refused, never normalised. Between samples the
last sample is held; `stamp` is the time the held sample was taken.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.math.validation import check_unit_vector
from testbed.pipeline import stage
from testbed.scenario.schema import join, param, whole_multiple
from testbed.stages.white_noise import WhiteNoise


@dataclass(kw_only=True)
class RateGyroParams:
    axis: list[float] = param(length=3, doc="unit sensing axis p, body axes")
    sample_period_s: float | None = param(None, gt=0, doc="default: the estimator period (sim.estimator_period_s)")
    noise_sigma_rad_s: float = param(0.0, ge=0, doc="white noise, standard deviation per sample")
    bias_rad_s: float = param(0.0, doc="constant bias")
    quantisation_rad_s: float = param(0.0, ge=0, doc="output step (0: none)")
    seed: int = param(0, ge=0, doc="noise seed: the same seed gives the same samples bit for bit")

    def validate(self, path: str) -> None:
        self.axis = list(check_unit_vector(self.axis, join(path, "axis")))


@stage("sensor", "rate_gyro", RateGyroParams)
class RateGyro:
    @classmethod
    def design(cls, params: RateGyroParams) -> dict:
        return {"outputs": ("y", "stamp"), "sensing_axis": list(params.axis)}

    def __init__(self, params: RateGyroParams, ctx):
        self.axis = np.asarray(params.axis, float)
        called = ctx.sample_period or ctx.control_period     # how often the pipeline calls the sensor
        period = params.sample_period_s or called
        field = "pipeline.sensor.sample_period_s"
        self.every = whole_multiple(period, ctx.dt, field, "the physics step sim.dt_s")
        multirate = called != ctx.control_period
        self.every_tick = whole_multiple(period, called, field,
                                         "sim.estimator_period_s" if multirate else "sim.control_period_s")
        self.params = params
        self.noise = WhiteNoise(params.seed)
        self.tick = 0
        self.y = np.zeros(1)
        self.stamp = np.zeros(1)

    def applied(self) -> dict:
        """The sensing axis and noise seed this gyro measures with (testbed.campaign.applied_values)."""
        return {"axis": self.axis.tolist(), "seed": self.noise.seed}

    def measure(self, t, plant):
        if self.tick % self.every_tick == 0:
            p = self.params
            y = self.noise.add(self.axis @ plant.omega() + p.bias_rad_s, p.noise_sigma_rad_s)
            if p.quantisation_rad_s:
                y = p.quantisation_rad_s * np.round(y / p.quantisation_rad_s)
            self.y = np.array([y])
            self.stamp = np.array([t])
        self.tick += 1
        return {"y": self.y, "stamp": self.stamp}

