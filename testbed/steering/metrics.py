"""Metrics of steering runs (the rhombus-cluster reorientation paper, docs/theory/papers.md): attitude reached, gimbal rates, singularity.

They apply to runs whose allocator is a steering law (testbed.steering); the attitude
metrics also need the `slew` law. The commanded-rate, rate-limit, singularity and
scale metrics count EVERY control step (the allocator keeps those extremes itself), whatever
the trace period; the others read the trace samples. The last trace row holds only the final
truth (no command was computed there), so command signals are reduced with nan-aware functions.
Each metric is a running reduction (testbed.recording.reductions) or an allocator statistic: a run keeps
no signal's history for them.
"""

from __future__ import annotations

import numpy as np

from testbed.metrics import metric
from testbed.math.quaternion import quat_angle, quat_conj, quat_mul
from testbed.recording.reductions import Last, MaxAbs, Mean, NanMax
from testbed.steering import STEERING_LAWS
from testbed.steering.stage import SteeringParams


def _steered(scenario) -> bool:
    """A steering allocator: a law of testbed.steering, or a stage built on their parameters."""
    return scenario.stages["allocator"][0] in STEERING_LAWS or isinstance(scenario.stages["allocator"][1],
                                                                        SteeringParams)


def _slewed(scenario) -> bool:
    return _steered(scenario) and scenario.stages["law"][0] == "slew"


def _torque_demanded(scenario) -> bool:
    return _steered(scenario) and scenario.stages["law"][0] != "none"


QUAT_LAST = Last("truth/quat")
TRACKING_ERROR_PEAK = NanMax("law/error_angle")
GIMBAL_RATE_PEAK = MaxAbs("truth/gimbal_rate")


def _angle_to(target, run) -> float:
    """Angle between the final bus attitude and `target` [deg]."""
    return float(np.degrees(quat_angle(quat_mul(quat_conj(target), run.reduced(QUAT_LAST)))))


@metric("final_attitude_error_deg", applies=_slewed, uses=(QUAT_LAST,))
def final_attitude_error_deg(run) -> float:
    """Angle between the final bus attitude and the slew's target q0 ∘ (axis, angle), turned on
    at the final rate past the slew's end [deg]: a run that ends before its slew does is
    measured against where the slew is to end, not against the program halfway."""
    return _angle_to(run.statistics["law"]["target_quat"], run)


@metric("final_tracking_error_deg", applies=_slewed, uses=(QUAT_LAST,))
def final_tracking_error_deg(run) -> float:
    """Angle between the final bus attitude and the program attitude Λ*(t) at that time [deg]."""
    return _angle_to(run.statistics["law"]["final_program_quat"], run)


@metric("max_tracking_error_deg", applies=_slewed, uses=(TRACKING_ERROR_PEAK,))
def max_tracking_error_deg(run) -> float:
    """max over control samples of the law's attitude error angle |Λ*~ ∘ q| [deg]."""
    return float(np.degrees(run.reduced(TRACKING_ERROR_PEAK)))


@metric("peak_gimbal_rate_deg_s", applies=_steered, uses=())
def peak_gimbal_rate_deg_s(run) -> float:
    """max over every control step and gimbal of the commanded |b'_i| [deg/s]."""
    return float(np.degrees(run.statistics["allocator"]["peak_gimbal_rate"]))


@metric("peak_gimbal_rate_measured_deg_s", applies=_steered, uses=(GIMBAL_RATE_PEAK,))
def peak_gimbal_rate_measured_deg_s(run) -> float:
    """max_t max_i |b'_i| of the true gimbal rates (servo output) [deg/s]."""
    return float(np.degrees(run.reduced(GIMBAL_RATE_PEAK)))


@metric("rate_limit_violations", applies=_steered, uses=())
def rate_limit_violations(run) -> float:
    """Count of commanded |b'_i| > b'max over every control step and gimbal (must be 0)."""
    return float(run.statistics["allocator"]["rate_limit_violations"])


@metric("peak_gimbal_acceleration_deg_s2", applies=_steered, uses=())
def peak_gimbal_acceleration_deg_s2(run) -> float:
    """max over every control step and gimbal of |b'_k - b'_(k-1)| / Tc, the commanded acceleration
    (the gimbals start at rest) [deg/s^2]; the servos' own transient within a period is faster."""
    return float(np.degrees(run.statistics["allocator"]["peak_gimbal_acceleration"]))


@metric("gimbal_acceleration_violations", applies=_steered, uses=())
def gimbal_acceleration_violations(run) -> float:
    """Count of commanded |b'_k - b'_(k-1)| > a_max Tc over every control step and gimbal (0 without a limit; must be 0)."""
    return float(run.statistics["allocator"]["acceleration_violations"])


@metric("gimbal_angle_limit_violations", applies=_steered, uses=())
def gimbal_angle_limit_violations(run) -> float:
    """Count of commanded gimbal angles (the servos' set-points) outside their [min, max] over every control step and gimbal (0 without limits; must be 0)."""
    return float(run.statistics["allocator"]["angle_limit_violations"])


def _angle_limited(scenario) -> bool:
    return _steered(scenario) and scenario.stages["allocator"][1].gimbal_angle_limits_deg is not None


@metric("min_gimbal_angle_margin_deg", applies=_angle_limited, uses=())
def min_gimbal_angle_margin_deg(run) -> float:
    """min over every control step and limited gimbal of the measured angle's distance to its nearer stop [deg] (< 0: beyond)."""
    return float(np.degrees(run.statistics["allocator"]["min_angle_margin"]))


@metric("min_singularity_measure", applies=_steered, uses=())
def min_singularity_measure(run) -> float:
    """min over every control step of m = sqrt(det(J J^T)) of the unit Jacobian (0: singular; 1.54 at most)."""
    return float(run.statistics["allocator"]["min_singularity"])


RATE_LIMITED = ("The rate limit scales a demand the gimbals cannot follow by one factor k <= 1, keeping "
                "its direction: a law whose gains ask for more torque than the cluster gives within its "
                "gimbal-rate limit is slowed down, not broken (docs/theory/steering.md).")


def _rate_limited(values: dict) -> bool:
    return values.get("min_scale", 1.0) < 1.0


@metric("min_scale", applies=_steered, uses=(), caveat=RATE_LIMITED, caveat_when=_rate_limited)
def min_scale(run) -> float:
    """Smallest factor k the rate limit applied to the demand over every control step (1: never limited)."""
    return float(run.statistics["allocator"]["min_scale"])


def _torque_squares(chunk):
    """|M_wanted - M_delivered|^2 and |M_wanted|^2 of the control samples (rows where both are finite)."""
    if "law/torque" not in chunk or "allocator/torque_delivered" not in chunk:
        return None
    wanted, delivered = chunk["law/torque"], chunk["allocator/torque_delivered"]
    keep = np.all(np.isfinite(wanted), axis=1) & np.all(np.isfinite(delivered), axis=1)
    wanted, delivered = wanted[keep], delivered[keep]
    return np.column_stack([np.sum((wanted - delivered) ** 2, axis=1), np.sum(wanted**2, axis=1)])


TORQUE_SQUARES = Mean(_torque_squares)


@metric("torque_error_rms", applies=_torque_demanded, uses=(TORQUE_SQUARES,))
def torque_error_rms(run) -> float:
    """RMS over control samples of |M_wanted - M_delivered| (law torque vs what the command produces) [N m]."""
    return float(np.sqrt(run.reduced(TORQUE_SQUARES)[0]))


@metric("torque_error_rel", applies=_torque_demanded, uses=(TORQUE_SQUARES,),
        caveat="Large by design when min_scale < 1: what the gimbal-rate limit cut from the law's demand "
               "counts as not delivered, though the run converges as designed (see min_scale).",
        caveat_when=lambda values: _rate_limited(values) and values.get("torque_error_rel", 0.0) > 0.01)
def torque_error_rel(run) -> float:
    """torque_error_rms / RMS |M_wanted|: the fraction of the wanted torque not delivered."""
    error, wanted = np.sqrt(run.reduced(TORQUE_SQUARES))
    return float(error / max(wanted, 1e-300))


def _fault_detecting(scenario) -> bool:
    return _steered(scenario) and scenario.stages["allocator"][1].fault_detection


@metric("isolated_unit", applies=_fault_detecting, uses=())
def isolated_unit(run) -> float:
    """The unit the fault detection declared failed first (1-based; 0: none, no alarm)."""
    return float(run.statistics["allocator"]["isolated_unit"])


@metric("isolation_time_s", applies=_fault_detecting, uses=())
def isolation_time_s(run) -> float:
    """Time the first unit was declared failed (its residual over threshold `persistence` ticks) [s]; NaN: none."""
    return float(run.statistics["allocator"]["isolation_time"])


@metric("detection_time_s", applies=_fault_detecting, uses=())
def detection_time_s(run) -> float:
    """Time the isolated unit's residual first went over its threshold, in the run that led to isolation [s]; NaN: none."""
    return float(run.statistics["allocator"]["detection_time"])
