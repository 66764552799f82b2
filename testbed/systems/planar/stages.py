"""Stages of the planar regulator (Avdeev & Kaptsova 2016, SEEDS §001).

- `hinge_encoder` (sensor): angle and rate of the hinge, ideal, optional white noise
  (seeded: the same seed gives the same samples bit for bit);
- `hinge_state` (estimator): passes (angle, rate) through as the state x;
- `akor_lqr` (law): u = -k (S12 x1 + S22 x2) (eq. 6), S from scipy's solve_continuous_are
  for the cost of eq. 3; u is an angular acceleration, so the torque is J u about the
  hinge, returned as a body torque (0, 0, J u) for the `ideal_torque` allocator.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.systems.planar.akor_regulator import lqr_gain
from testbed.errors import InputError
from testbed.pipeline import stage
from testbed.scenario.schema import param
from testbed.stages.white_noise import WhiteNoise


@dataclass(kw_only=True)
class HingeEncoderParams:
    angle_noise_rad: float = param(0.0, ge=0, doc="white noise on the angle, std per sample")
    rate_noise_rad_s: float = param(0.0, ge=0, doc="white noise on the rate, std per sample")
    seed: int = param(0, ge=0, doc="noise seed")


def _planar_only(ctx, slot: str, name: str) -> None:
    if ctx.system != "planar":
        raise InputError(f"pipeline.{slot}.type", f"{name} needs model.system: planar, got {ctx.system!r}")


@stage("sensor", "hinge_encoder", HingeEncoderParams)
class HingeEncoder:
    outputs = ("angle", "rate")

    def __init__(self, params: HingeEncoderParams, ctx):
        _planar_only(ctx, "sensor", "hinge_encoder")
        self.params = params
        self.noise = WhiteNoise(params.seed)

    def measure(self, t, plant):
        p = self.params
        angle = self.noise.add(plant.angle(), p.angle_noise_rad)
        rate = self.noise.add(plant.rate(), p.rate_noise_rad_s)
        return {"angle": np.array([angle]), "rate": np.array([rate])}


@stage("estimator", "hinge_state")
class HingeState:
    """x = (angle, rate), the measurement unchanged."""

    outputs = ("x",)

    def __init__(self, params, ctx):
        sensor = ctx.stages["sensor"]
        if not {"angle", "rate"} <= sensor.outputs:
            raise InputError("pipeline.estimator.type", f"hinge_state needs sensor hinge_encoder, got {sensor.type!r}")

    def estimate(self, t, measurement, command):
        return {"x": np.array([measurement["angle"][0], measurement["rate"][0]])}


@dataclass(kw_only=True)
class AkorLqrParams:
    """Cost of eq. 3: integral of beta11 x1^2 + beta22 x2^2 + u^2 / k."""

    # bounded where the closed-form Riccati solution (and scipy's) stays accurate
    beta11: float = param(ge=1e-9, le=1e9, doc="angle weight beta11 > 0")
    beta22: float = param(ge=0, le=1e9, doc="rate weight beta22 >= 0")
    k: float = param(ge=1e-9, le=1e9, doc="control weight: u enters the cost as u^2 / k")


@stage("law", "akor_lqr", AkorLqrParams)
class AkorLqr:
    def __init__(self, params: AkorLqrParams, ctx):
        _planar_only(ctx, "law", "akor_lqr")
        if "x" not in ctx.stages["estimator"].outputs:
            raise InputError("pipeline.estimator.type", "akor_lqr needs the state x = (angle, rate) "
                             f"(estimator hinge_state), got {ctx.stages['estimator'].type!r}")
        self.gain = lqr_gain(params.beta11, params.beta22, params.k)  # k (S12, S22)
        self.J = float(ctx.description["hinge_inertia_kg_m2"])

    def torque(self, t, estimate):
        u = -float(self.gain @ estimate["x"])
        return {"torque": np.array([0.0, 0.0, self.J * u]), "u": np.array([u])}
