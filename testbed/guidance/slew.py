"""The `slew` law: follow a program rotation (SEEDS §004 stage 1) with the tracking law.

The program Λ*(t) goes from the scenario's initial attitude q0 to qT = q0 ∘ (axis, angle)
(a rotation about a body axis) in duration_s, starting at start_s, with the boundary body
rates initial_rate_deg_s and final_rate_deg_s (eq. 3, 10-13; rest to rest by default: the
eigen-axis slew). A rest-to-rest slew may follow a smooth `profile` (versine, s-curve) and an
input `shaper` (ZV, ZVD at given modes), which lengthens it by the shaper's duration
(testbed.guidance.rest_to_rest_profiles, testbed.shaping.shapers); `settle_pointing_deg` and
`settle_rate_deg_s` ask for the settling metrics (testbed.guidance.settling_metrics). The
wanted torque is the program torque M* (eq. 9) plus quaternion PD feedback with gyroscopic
compensation (testbed.guidance.tracking_law), designed on the locked system inertia
ctx.inertia. Before start_s the program holds q0 (rest start);
after the slew it holds qT (or spins on at the final rate).

Records `law/torque`, the program `program_quat`, `program_omega`, `program_torque`, and the
attitude error as a rotation vector `attitude_error` [rad, body axes] and its angle `error_angle`;
declares the slew's target at the run's end (`target_quat`: q0 ∘ (axis, angle), from the
scenario's numbers), the program attitude at the run's last sample (`final_program_quat`) and
when the program comes to rest (`slew_end_s`: start_s + T + the shaper's duration).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from testbed.errors import InputError
from testbed.batch.stacked_stages import StatelessForm
from testbed.guidance.program_trajectory import ProgramTrajectory, ProgramWorlds
from testbed.guidance.rest_to_rest_profiles import NO_SHAPER, RestToRestProfile
from testbed.math.cross import cross3
from testbed.guidance.tracking_law import TrackingLaw, TrackingWorlds
from testbed.math.validation import check_unit_vector
from testbed.pipeline import require_attitude_estimate, require_free_body, stage
from testbed.math.quaternion import length_column, quat_conj, quat_from_axis_angle, quat_mul, rotation_vector
from testbed.scenario.schema import join, param
from testbed.shaping.shapers import shaper_for

ZERO3 = [0.0, 0.0, 0.0]
# Library field names (testbed.guidance) -> this stage's scenario keys, for error messages.
_FIELDS = {"slew.duration_s": "duration_s", "slew.axis": "axis", "slew.angle_rad": "angle_deg",
           "slew.w_initial_rad_s": "initial_rate_deg_s", "slew.w_target_rad_s": "final_rate_deg_s",
           "control.natural_frequency_rad_s": "natural_frequency_rad_s",
           "control.damping_ratio": "damping_ratio"}
LAW_PATH = "pipeline.law"


@dataclass(kw_only=True)
class ShaperParams:
    type: Literal["zv", "zvd"] = param(doc="zero vibration (2 impulses) or zero vibration and derivative (3)")
    frequency_hz: list[float] = param(doc="the modes' natural frequencies (one shaper each, convolved)")
    damping_ratio: list[float] = param(doc="the modes' damping ratios, one per frequency, in [0, 1)")

    def validate(self, path: str) -> None:
        self.impulses = shaper_for(self.type, self.frequency_hz, self.damping_ratio, path)


@dataclass(kw_only=True)
class SlewParams:
    axis: list[float] = param(length=3, doc="unit rotation axis, body axes at the start")
    angle_deg: float = param(ge=-180.0, le=180.0, doc="slew angle about axis")
    duration_s: float = param(gt=0, doc="slew time T")
    start_s: float = param(0.0, ge=0, doc="when the slew begins")
    initial_rate_deg_s: list[float] = param(ZERO3, length=3, doc="program body rate at start_s")
    final_rate_deg_s: list[float] = param(ZERO3, length=3, doc="program body rate at start_s + T")
    natural_frequency_rad_s: float = param(0.5, gt=0, doc="tracking-error natural frequency")
    damping_ratio: float = param(0.9, ge=0, doc="tracking-error damping ratio")
    profile: Literal["cubic", "versine", "s_curve"] = param("cubic", doc="rest-to-rest angle profile "
                                                              "(docs/theory/slew-and-settle.md)")
    # ramps shorter than a thousandth of T are a step: the jerk's 1/ramp scale would drown the profile's precision
    jerk_fraction: float = param(0.5, ge=1e-3, le=1, doc="s_curve: share of T spent in the four jerk ramps")
    coast_fraction: float = param(0.0, ge=0, lt=1, doc="s_curve: share of T coasting at the peak rate")
    shaper: ShaperParams | None = param(None, doc="input shaper of the program (absent: none)")
    settle_pointing_deg: float | None = param(None, gt=0, doc="pointing bound of the settling metric (absent: "
                                              "no such metric)")
    settle_rate_deg_s: float | None = param(None, gt=0, doc="rate-jitter bound of the settling metric (absent: "
                                            "no such metric)")

    def validate(self, path: str) -> None:
        self.axis = list(check_unit_vector(self.axis, join(path, "axis")))
        if self.jerk_fraction + self.coast_fraction > 1.0:
            raise InputError(join(path, "coast_fraction"), f"jerk_fraction + coast_fraction must be <= 1, got "
                             f"{self.jerk_fraction:g} + {self.coast_fraction:g}")
        settling = self.settle_pointing_deg is not None or self.settle_rate_deg_s is not None
        if settling and np.any(self.final_rate_deg_s):
            raise InputError(join(path, "final_rate_deg_s"), "the settling metrics measure a slew to rest: must be 0 "
                             "with settle_pointing_deg or settle_rate_deg_s")
        smooth = self.profile != "cubic" or self.shaper is not None
        if smooth and (np.any(self.initial_rate_deg_s) or np.any(self.final_rate_deg_s)):
            raise InputError(join(path, "profile" if self.shaper is None else "shaper"),
                             "smooth profiles and shapers fly rest-to-rest slews: initial and final rates must be 0")

    def rest_to_rest_profile(self) -> RestToRestProfile | None:
        """The profile and shaper of the scenario (None: the cubic of SEEDS §004, unshaped)."""
        if self.profile == "cubic" and self.shaper is None:
            return None
        impulses = NO_SHAPER if self.shaper is None else self.shaper.impulses
        return RestToRestProfile(self.profile, self.duration_s, impulses, self.jerk_fraction, self.coast_fraction)


def build_program(params: SlewParams, q0) -> ProgramTrajectory:
    """The program of SEEDS §004 eq. (5)-(13) from q0 to q0 ∘ (axis, angle); errors name scenario keys."""
    try:
        q0 = np.asarray(q0, float) / np.linalg.norm(q0)
        axis, angle = np.asarray(params.axis, float), np.radians(params.angle_deg)
        w0, wT = np.radians(params.initial_rate_deg_s), np.radians(params.final_rate_deg_s)
        if not np.any(w0) and not np.any(wT):
            return ProgramTrajectory.eigen_axis_slew(q0, axis, angle, params.duration_s,
                                                     params.rest_to_rest_profile())
        qT = quat_mul(q0, quat_from_axis_angle(axis, angle))
        return ProgramTrajectory.from_boundary(q0, w0, qT, wT, params.duration_s)
    except InputError as exc:
        raise InputError(join(LAW_PATH, _FIELDS.get(exc.field, exc.field)), exc.reason) from None


def slew_target(params: SlewParams, q0, t) -> np.ndarray:
    """The attitude the slew is to bring the body to by time t, from the scenario's own numbers
    (not the program): qT = q0 ∘ (axis, angle), turned on past start_s + duration_s at the final
    body rate (SEEDS §004 eq. 12: the program ends at qT with rate ω_T, then spins on at it)."""
    q0 = np.asarray(q0, float) / np.linalg.norm(q0)
    target = quat_mul(q0, quat_from_axis_angle(np.asarray(params.axis, float), np.radians(params.angle_deg)))
    rate = np.radians(np.asarray(params.final_rate_deg_s, float))
    speed = float(np.linalg.norm(rate))
    after = max(0.0, t - params.start_s - params.duration_s)
    if speed == 0.0 or after == 0.0:
        return target
    return quat_mul(target, quat_from_axis_angle(rate / speed, speed * after))


@stage("law", "slew", SlewParams)
class Slew:
    def __init__(self, params: SlewParams, ctx):
        require_free_body(ctx, "law", "slew")
        require_attitude_estimate(ctx, "the slew law")
        self.start = params.start_s
        self.angle_deg = params.angle_deg
        self.program = build_program(params, ctx.initial.quat)
        try:
            self.tracking = TrackingLaw(self.program, ctx.inertia, params.natural_frequency_rad_s,
                                        params.damping_ratio)
        except InputError as exc:
            raise InputError(join(LAW_PATH, _FIELDS.get(exc.field, exc.field)), exc.reason) from None
        self.inertia = self.tracking.inertia
        # where the run should end: the slew's target, and the program at the last sample
        self.statistics = {"target_quat": slew_target(params, ctx.initial.quat, ctx.end_time),
                           "final_program_quat": self.program.attitude(ctx.end_time - self.start),
                           "slew_end_s": self.start + self.program.end}

    @classmethod
    def design(cls, params: SlewParams) -> dict:
        # the program's parameters, for an allocator that plans its actuators' path before the slew
        return {"slew_program": params}

    def applied(self) -> dict:
        """Axis, angle and duration of the program this law tracks, read from the program itself
        (its start and target attitudes), in the scenario's keys (testbed.campaign.applied_values)."""
        turn = rotation_vector(quat_mul(quat_conj(self.program.attitude(0.0)), self.program.q_ref))
        angle = float(np.linalg.norm(turn))
        sign = -1.0 if self.angle_deg < 0 else 1.0  # (axis, -angle) is stored as (-axis, angle)
        axis = sign * turn / angle if angle else np.full(3, np.nan)
        return {"axis": axis.tolist(), "angle_deg": sign * float(np.degrees(angle)),
                "duration_s": self.program.duration}

    @classmethod
    def batched(cls, stages: list) -> StatelessForm:
        """The law on many worlds: its own `torque` on their stacked programs and tracking laws."""
        program = ProgramWorlds([stage.program for stage in stages])
        tracking = TrackingWorlds([stage.tracking for stage in stages], program)
        return StatelessForm(stages, "law", ("start", "inertia"), {"program": program, "tracking": tracking})

    def torque(self, t, estimate):
        tau = t - self.start
        torque, dq, _ = self.tracking.torque_and_errors(tau, estimate["quat"], estimate["omega"])
        q_p, w_p, dw_p = self.program.state(tau)
        error = rotation_vector(dq)
        return {"torque": torque, "program_quat": q_p, "program_omega": w_p,
                "program_torque": np.matvec(self.inertia, dw_p) + cross3(w_p, np.matvec(self.inertia, w_p)),
                "attitude_error": error, "error_angle": length_column(error)}
