"""Ideal attitude sensing: a star tracker (attitude) and a 3-axis rate gyro (body rate).

`ideal_attitude` (sensor) reads the true bus attitude q and body rate w every control tick.
Optional white noise: the star tracker reports q ∘ exp(δθ/2), δθ ~ N(0, σ_q² I) a small
body-frame rotation [rad] (so the error angle is about |δθ|), the gyro w + N(0, σ_w² I).
The same seed gives the same samples bit for bit. `attitude` (estimator) passes the
measured quat and omega through unchanged: with noise off, the law sees the truth.
"""

from __future__ import annotations

from dataclasses import dataclass

from testbed.errors import InputError
from testbed.pipeline import stage
from testbed.math.quaternion import quat_from_rotation_vector, quat_mul
from testbed.scenario.schema import param
from testbed.stages.white_noise import WhiteNoise


@dataclass(kw_only=True)
class IdealAttitudeParams:
    attitude_noise_rad: float = param(0.0, ge=0, doc="star-tracker noise, std of each small-angle component")
    rate_noise_rad_s: float = param(0.0, ge=0, doc="gyro white noise, std per axis and sample")
    seed: int = param(0, ge=0, doc="noise seed")


@stage("sensor", "ideal_attitude", IdealAttitudeParams)
class IdealAttitude:
    outputs = ("quat", "omega")

    def __init__(self, params: IdealAttitudeParams, ctx):
        self.params = params
        self.noise = WhiteNoise(params.seed)

    def applied(self) -> dict:
        """The noise seed this sensor draws with (testbed.campaign.applied_values)."""
        return {"seed": self.noise.seed}

    def measure(self, t, plant):
        p = self.params
        quat = plant.quat()
        if p.attitude_noise_rad:
            quat = quat_mul(quat, quat_from_rotation_vector(self.noise.add(0.0, p.attitude_noise_rad, 3)))
        omega = self.noise.add(plant.omega(), p.rate_noise_rad_s, 3)
        return {"quat": quat, "omega": omega}


@stage("estimator", "attitude")
class AttitudePassThrough:
    """Estimate = measurement: quat and omega from the attitude sensor, unchanged."""

    outputs = ("quat", "omega")

    def __init__(self, params, ctx):
        sensor = ctx.stages["sensor"]
        if not {"quat", "omega"} <= sensor.outputs:
            raise InputError("pipeline.estimator.type", f"attitude needs a sensor that measures quat and "
                             f"omega (e.g. ideal_attitude), got sensor {sensor.type!r}")

    def estimate(self, t, measurement, command):
        return {"quat": measurement["quat"], "omega": measurement["omega"]}
