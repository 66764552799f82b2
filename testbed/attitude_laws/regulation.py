"""What both laws share: the target attitude, the error, and the gyroscopic compensation."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.attitude_laws.momentum_input import DESIGN, INPUT, check_allocator
from testbed.batch.stacked_stages import StatelessForm
from testbed.math.cross import cross3
from testbed.math.quaternion import length_column, quat_conj, quat_from_axis_angle, quat_mul, rotation_vector
from testbed.math.validation import check_unit_vector
from testbed.pipeline import require_attitude_estimate, require_free_body
from testbed.scenario.schema import join, param


@dataclass(kw_only=True)
class TargetParams:
    axis: list[float] = param([1.0, 0.0, 0.0], length=3, doc="unit rotation axis to the target, body axes at the start")
    angle_deg: float = param(0.0, ge=-180.0, le=180.0, doc="angle to the target (0: hold the initial attitude)")
    start_s: float = param(0.0, ge=0, doc="when the target steps from the initial attitude to q0 o (axis, angle)")

    def validate(self, path: str) -> None:
        self.axis = list(check_unit_vector(self.axis, join(path, "axis")))


class Regulator:
    """Base of a law towards a fixed target q_t = q0 ∘ (axis, angle), q0 the scenario's start.
    Its arithmetic broadcasts over a leading axis of worlds (testbed.batch.stacked_stages):
    `per_world` names what differs from world to world."""

    inputs = (INPUT,)
    name = ""
    per_world = ("inertia", "start_quat", "target", "start")

    @classmethod
    def batched(cls, stages: list) -> StatelessForm:
        """The law on many worlds: its own `torque` on their stacked targets, gains and inertias."""
        return StatelessForm(stages, "law", cls.per_world)

    @classmethod
    def design(cls, params) -> dict:
        return dict(DESIGN)

    def __init__(self, params, ctx):
        require_free_body(ctx, "law", self.name)
        require_attitude_estimate(ctx, self.name)
        check_allocator(ctx, self.name)
        self.inertia = np.asarray(ctx.inertia, float)
        self.start_quat = np.asarray(ctx.initial.quat, float) / np.linalg.norm(ctx.initial.quat)
        self.target = quat_mul(self.start_quat, quat_from_axis_angle(np.asarray(params.axis), np.radians(params.angle_deg)))
        self.start = params.start_s
        self.statistics = {"target_quat": self.target}

    def error(self, t: float, quat) -> np.ndarray:
        """q_e = q_t~ ∘ q, the short way (q_e,w >= 0)."""
        target = np.where(t >= self.start, self.target, self.start_quat)
        error = quat_mul(quat_conj(target), quat)
        return np.where(error[..., :1] >= 0, error, -error)

    def gyroscopic(self, omega, momentum) -> np.ndarray:
        """ω × (I ω + H) [N m]."""
        return cross3(omega, np.matvec(self.inertia, omega) + momentum)

    def signals(self, torque, error, momentum) -> dict:
        """What a regulator records: `torque`, the error as a rotation vector `attitude_error` [rad]
        and its angle `error_angle`, and the `internal_momentum` H it compensated with [N m s]."""
        angle = rotation_vector(error)
        return {"torque": torque, "attitude_error": angle,
                "error_angle": length_column(angle),
                "internal_momentum": momentum}
