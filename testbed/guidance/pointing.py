"""The `pointing` law: hold an attitude fixed in a target frame with the tracking law
(testbed.guidance.tracking_law): `inertial` (ECI), `nadir` (the orbit's LVLH frame, x
along-track, y opposite the orbit normal, z nadir: testbed.orbit.frames) or `sun` (z toward
the Sun, y opposite the ecliptic pole: testbed.guidance.sun_frame).

The target attitude is Λ*(t) = q_frame(t) ∘ q_offset, its rate ω* = R(q_offset)^T ω_frame and
acceleration likewise (ω_frame = (0, -|h|/r², 0) in LVLH, (0, -ω_sun, 0) in the Sun frame, zero
for inertial), from the law's own
copy of the orbit (the scenario's `orbit:` block, propagated on the same grid as the truth's:
an on-board ephemeris, not the truth). Records `law/torque`, `target_quat`, `target_omega`, and
the attitude error in the target frame as a rotation vector `attitude_error` [rad] and its
angle `error_angle` [rad].
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import mujoco
import numpy as np

from testbed.errors import InputError
from testbed.guidance.sun_frame import sun_frame
from testbed.guidance.tracking_law import TrackingLaw
from testbed.math.quaternion import quat_conj, quat_rotate, rotation_vector
from testbed.math.validation import unit_quaternion
from testbed.orbit.frames import lvlh_quat, lvlh_rate
from testbed.pipeline import require_attitude_estimate, require_free_body, stage
from testbed.scenario.schema import join, param

LAW_PATH = "pipeline.law"


@dataclass(kw_only=True)
class PointingParams:
    target: Literal["inertial", "nadir", "sun"] = param("nadir", doc="frame the attitude is held in (sun: "
                                                        "z toward the Sun, y opposite the ecliptic pole)")
    quat: list[float] | None = param(None, length=4, doc="attitude (w, x, y, z) to hold, body to target frame "
                                     "(default: the initial attitude for inertial, identity for nadir and sun)")
    natural_frequency_rad_s: float = param(0.5, gt=0, doc="tracking-error natural frequency")
    damping_ratio: float = param(0.9, ge=0, doc="tracking-error damping ratio")

    def validate(self, path: str) -> None:
        if self.quat is not None:
            self.quat = list(unit_quaternion(join(path, "quat"), self.quat))


class HeldAttitude:
    """Λ*(t), ω*(t), ω*'(t) of an attitude q_offset held in a frame that turns about its own y axis
    with `frame(t) -> (q_frame, ω_frame, ω_frame')` (frame axes; LVLH turns about y), or in ECI."""

    def __init__(self, offset, frame=None):
        self.offset = np.asarray(offset, float)
        self.frame = frame
        self.y_in_body = quat_rotate(quat_conj(self.offset), np.array([0.0, 1.0, 0.0]))  # R(q_offset)^T e_y
        self._last = (None, None)

    def state(self, t):
        if self.frame is None:
            return self.offset, np.zeros(3), np.zeros(3)
        if self._last[0] == t:  # the law and its record ask for one instant twice
            return self._last[1]
        q_frame, rate, acceleration = self.frame(t)
        target = np.empty(4)
        mujoco.mju_mulQuat(target, q_frame, self.offset)
        state = target, rate[1] * self.y_in_body, acceleration[1] * self.y_in_body
        self._last = (t, state)
        return state


def lvlh_frame(orbit):
    """frame(t) of the LVLH axes along `orbit` (a testbed.orbit.propagation.Orbit)."""

    def frame(t):
        r, v = orbit.state(t)
        rate, acceleration = lvlh_rate(r, v)
        return lvlh_quat(r, v), rate, acceleration

    return frame


@stage("law", "pointing", PointingParams)
class Pointing:
    """Hold an attitude in ECI (inertial) or in LVLH (nadir) with the tracking law."""

    def __init__(self, params: PointingParams, ctx):
        require_free_body(ctx, "law", "pointing")
        require_attitude_estimate(ctx, "the pointing law")
        if params.target in ("nadir", "sun"):
            if ctx.orbit is None:
                raise InputError(join(LAW_PATH, "target"), f"{params.target} pointing needs an orbit: add an orbit: block")
            frame = (lvlh_frame(ctx.orbit.propagator()) if params.target == "nadir"
                     else sun_frame(ctx.orbit.propagator(), ctx.orbit.epoch()))
            program = HeldAttitude(params.quat or [1.0, 0.0, 0.0, 0.0], frame)
        else:
            program = HeldAttitude(params.quat or ctx.initial.quat)
        try:
            self.tracking = TrackingLaw(program, ctx.inertia, params.natural_frequency_rad_s, params.damping_ratio)
        except InputError as exc:
            raise InputError(join(LAW_PATH, exc.field.rpartition(".")[2]), exc.reason) from None
        self.program = program

    def torque(self, t, estimate):
        torque, dq, _ = self.tracking.torque_and_errors(t, estimate["quat"], estimate["omega"])
        error = rotation_vector(dq)
        q_p, w_p, _ = self.program.state(t)
        return {"torque": torque, "target_quat": q_p, "target_omega": w_p, "attitude_error": error,
                "error_angle": np.array([np.linalg.norm(error)])}
