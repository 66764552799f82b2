"""The allocator `hybrid_split`: the law's body torque split between the reaction wheels and the CMGs
of a hybrid bus (docs/theory/reaction-wheels.md, "Hybrid bus").

Fine to the wheels, coarse to the CMGs (eq. (HY-1)): the wheels take the demand up to the
torque tau_f they deliver in every direction, keeping its direction, and the CMGs the rest,

    M_w = M min(1, tau_f / |M|),   M_c = M - M_w.

A hold or a fine correction is then flown by the wheels alone (the gimbals stay still: no
gimbal-rate jitter, no singular state to meet), and a slew's large torque by the CMGs, whose
steering law is one of the cluster's own (`steering`, with every SteeringParams field). tau_f
is `wheel_torque_nm` or, by default, the radius of the largest ball of torques the wheels'
minimum-norm allocation delivers within the motors' limits: u = A^+ M fits when
|(A^+)_i M| <= u_max,i for every wheel i, so (HY-2)

    tau_f = min_i u_max,i / |(A^+)_i|     ((A^+)_i the i-th row of the pseudo-inverse).

What the CMGs' steering does not deliver of M_c (its shortfall: a demand scaled to the gimbal-rate
limit, or the torque an SR-type law gives up near a singular set) the wheels take too, on top of
M_w, when `wheels_take_shortfall` (the default; eq. (HY-3)): M_w' = M_w + (M_c - M_c,delivered).
Their own limits then scale their whole part.

Each part goes to its own allocator (the steering law's and `wheel_pinv` or `wheel_minimax`),
built on the part of the bus it drives; each adds w x (its own H) unless the law compensates
w x H itself, so together they add w x (H_c + H_w). The command carries both actuators' keys;
`torque_delivered` and `momentum` are the sums, `wheel_share` records |M_w| / |M| and `shortfall`
the CMGs' (HY-3).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Literal

import numpy as np

from testbed.errors import InputError
from testbed.pipeline import stage, stage_class
from testbed.scenario.schema import join, param
from testbed.steering import STEERING_LAWS
from testbed.steering.stage import SteeringParams
from testbed.systems.cmg_cluster.hybrid_plant import HybridBus
from testbed.systems.reaction_wheels.allocator import WheelAllocationParams
from testbed.systems.reaction_wheels.minimax_allocation import WheelMinimaxParams

PATH = "pipeline.allocator"


@dataclass(kw_only=True)
class HybridSplitParams(SteeringParams, WheelAllocationParams):
    steering: str = param("minimax", doc="the CMGs' steering law (any allocator of the steering family)")
    wheel_allocator: Literal["wheel_pinv", "wheel_minimax"] = param("wheel_pinv", doc="how the wheels' part is spread")
    wheels_take_shortfall: bool = param(True, doc="the wheels also take what the CMGs' steering did not deliver (HY-3)")
    wheel_torque_nm: float | None = param(None, gt=0, le=1e6, doc="tau_f: the largest torque the wheels take "
                                          "(default: the most they deliver in every direction, eq. (HY-2))")

    def validate(self, path: str) -> None:
        if self.steering not in STEERING_LAWS:
            raise InputError(join(path, "steering"), f"unknown steering law {self.steering!r} "
                             f"(known: {', '.join(sorted(STEERING_LAWS))})")
        if self.wheel_allocator == "wheel_minimax" and (self.null_space_gain_per_s or self.preferred_momentum_nms):
            raise InputError(join(path, "wheel_allocator"), "wheel_minimax has no null-space momentum management: "
                             "drop null_space_gain_per_s and preferred_momentum_nms, or take wheel_pinv")
        super().validate(path)


def isotropic_wheel_torque(inverse: np.ndarray, torque_max: np.ndarray) -> float:
    """tau_f of (HY-2) [N m]: min_i u_max,i / |(A^+)_i|, the radius of the largest ball of body
    torques whose minimum-norm wheel torques A^+ M stay within the limits `torque_max` (n,) [N m];
    `inverse` A^+ (n, 3)."""
    return float(np.min(torque_max / np.linalg.norm(inverse, axis=1)))


def fine_part(torque: np.ndarray, limit: float) -> np.ndarray:
    """M_w of (HY-1) [N m]: `torque` M (3,) itself when |M| <= `limit` tau_f, else M scaled to |M| = tau_f."""
    size = float(np.linalg.norm(torque))
    return torque if size <= limit else torque * (limit / size)


@stage("allocator", "hybrid_split", HybridSplitParams)
class HybridSplit:
    """Fine torque to the wheels, the rest to the CMGs' steering law (eq. (HY-1))."""

    output = "gimbal_rates"

    @classmethod
    def design(cls, params: HybridSplitParams) -> dict:
        return stage_class("allocator", params.steering).design(params)

    def __init__(self, params: HybridSplitParams, ctx):
        if not isinstance(ctx.description, HybridBus):
            raise InputError(f"{PATH}.type", "hybrid_split needs a bus with both CMGs and reaction wheels "
                                             f"(model.system cmg_cluster with model.wheels), not {ctx.system}")
        bus = ctx.description
        steering_params = SteeringParams(**{f.name: getattr(params, f.name) for f in dataclasses.fields(SteeringParams)})
        self.steering = stage_class("allocator", params.steering)(steering_params, dataclasses.replace(
            ctx, description=bus.cluster))
        if params.wheel_allocator == "wheel_minimax":
            wheel_params = WheelMinimaxParams(compensate_friction=params.compensate_friction)
        else:
            wheel_params = WheelAllocationParams(
                **{f.name: getattr(params, f.name) for f in dataclasses.fields(WheelAllocationParams)})
        self.wheels = stage_class("allocator", params.wheel_allocator)(wheel_params, dataclasses.replace(
            ctx, description=bus.wheels))
        self.limit = (isotropic_wheel_torque(self.wheels.inverse, bus.wheels.torque_max)
                      if params.wheel_torque_nm is None else params.wheel_torque_nm)
        self.take_shortfall = params.wheels_take_shortfall
        self.min_wheel_scale = 1.0

    @property
    def statistics(self) -> dict:
        """The steering law's counts (what the CMG metrics read) and the least wheel scale."""
        return self.steering.statistics | {"min_wheel_scale": self.min_wheel_scale}

    def applied(self) -> dict:
        return self.steering.applied() | {"wheel_torque_nm": self.limit}

    def allocate(self, t, demand, estimate, actuators):
        torque = np.asarray(demand.get("torque", np.zeros(3)), dtype=float)
        fine = fine_part(torque, self.limit)
        cmgs = self.steering.allocate(t, demand | {"torque": torque - fine}, estimate, actuators)
        # the CMGs' delivered torque already holds -w x H_c, as their demand did: the difference is
        # what the steering gave up (HY-3)
        shortfall = (torque - fine) - cmgs["torque_delivered"] if self.take_shortfall else np.zeros(3)
        wheels = self.wheels.allocate(t, demand | {"torque": fine + shortfall}, estimate, actuators)
        size = float(np.linalg.norm(torque))
        self.min_wheel_scale = min(self.min_wheel_scale, float(wheels["scale"][0]))
        return cmgs | {"wheel_torques": wheels["wheel_torques"],
                       "torque_delivered": cmgs["torque_delivered"] + wheels["torque_delivered"],
                       "momentum": cmgs["momentum"] + wheels["momentum"],
                       "held_momentum": cmgs["held_momentum"] + wheels["momentum"],
                       "wheel_scale": wheels["scale"],
                       "wheel_share": np.array([float(np.linalg.norm(fine)) / size if size else 0.0]),
                       "shortfall": shortfall}
