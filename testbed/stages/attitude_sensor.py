"""Ideal attitude sensing: a star tracker (attitude) and a 3-axis rate gyro (body rate).

`ideal_attitude` (sensor) reads the true bus attitude q and body rate w every control tick.
Optional white noise: the star tracker reports q ∘ exp(δθ/2), δθ ~ N(0, σ_q² I) a small
body-frame rotation [rad] (so the error angle is about |δθ|), the gyro w + N(0, σ_w² I).
The same seed gives the same samples bit for bit. `attitude` (estimator) passes the
measured quat and omega through unchanged: with noise off, the law sees the truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.batch.stacked_stages import StatelessForm
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

    @classmethod
    def batched(cls, stages: list) -> "IdealAttitudeWorlds":
        return IdealAttitudeWorlds(stages)

    def applied(self) -> dict:
        """The noise seed this sensor draws with (testbed.campaign.applied_values)."""
        return {"seed": self.noise.seed}

    def draws(self) -> tuple:
        """This tick's (star-tracker error rotation vector [rad] or None, gyro noise [rad/s] or 0),
        drawn in that order from the sensor's own generator."""
        p = self.params
        turn = self.noise.add(0.0, p.attitude_noise_rad, 3) if p.attitude_noise_rad else None
        return turn, self.noise.add(0.0, p.rate_noise_rad_s, 3)

    def measure(self, t, plant):
        turn, rate_noise = self.draws()
        return noisy_attitude(plant.quat(), plant.omega(), turn, rate_noise)


def noisy_attitude(quat, omega, turn, rate_noise) -> dict:
    """The measured quat = q ∘ exp(turn / 2) (turn None: q) and omega = ω + rate_noise, on
    (..., 4) and (..., 3) arrays (module doc)."""
    if turn is not None:
        quat = quat_mul(quat, quat_from_rotation_vector(turn))
    return {"quat": quat, "omega": omega + rate_noise}


class IdealAttitudeWorlds:
    """`ideal_attitude` on many worlds: each world's truth and its own generator's draws (the
    same numbers as its single run), the rotation applied on (N, ...) rows."""

    def __init__(self, stages: list):
        self.stages = list(stages)
        self._noisy()

    def _noisy(self) -> None:
        self.noisy = [row for row, stage in enumerate(self.stages)
                      if stage.params.attitude_noise_rad or stage.params.rate_noise_rad_s]

    def keep(self, rows) -> None:
        self.stages = [self.stages[i] for i in rows]
        self._noisy()

    def settle(self, row: int) -> None:
        """Nothing to write back: each world's generator is its own stage's."""

    def measure(self, t, plants: list) -> dict:
        quat = np.array([plant.quat() for plant in plants])
        omega = np.array([plant.omega() for plant in plants])
        if not self.noisy:
            return noisy_attitude(quat, omega, None, 0.0)
        turn, rate_noise = np.zeros((len(plants), 3)), np.zeros((len(plants), 3))
        for row in self.noisy:  # a world without attitude noise turns by zero: exp(0) = 1 exactly
            drawn, rate_noise[row] = self.stages[row].draws()
            if drawn is not None:
                turn[row] = drawn
        return noisy_attitude(quat, omega, turn, rate_noise)


@stage("estimator", "attitude")
class AttitudePassThrough:
    """Estimate = measurement: quat and omega from the attitude sensor, unchanged."""

    outputs = ("quat", "omega")

    def __init__(self, params, ctx):
        sensor = ctx.stages["sensor"]
        if not {"quat", "omega"} <= sensor.outputs:
            raise InputError("pipeline.estimator.type", f"attitude needs a sensor that measures quat and "
                             f"omega (e.g. ideal_attitude), got sensor {sensor.type!r}")

    @classmethod
    def batched(cls, stages: list) -> StatelessForm:
        return StatelessForm(stages, "estimator", ())

    def estimate(self, t, measurement, command):
        return {"quat": measurement["quat"], "omega": measurement["omega"]}
