"""A user's own slew controller for the 4-CMG bus, as a plug-in (examples/pd_steering.yaml).

Written against the public API only (`import testbed`). It registers:

- law `user.quaternion_pd`: quaternion-feedback PD to a target attitude q_T = q0 o (axis, angle),

      q_e = q_T~ o q  (short way: w_e >= 0),   e = 2 vec(q_e)  [rad]
      M   = -I (kp e + kd w) + w x (I w)       [N m, body axes],  kp = wn^2, kd = 2 zeta wn

  The steering below already adds the cluster's own gyroscopic term w x H (it asks the
  cluster for H' = -(M + w x H)), so the bus obeys I w' + w x I w = M and the law compensates
  w x I w only.
- allocator `user.weighted_pinv`: gimbal rates from the wanted torque by a weighted
  pseudo-inverse with a diagonal weight W = diag(weights),

      H' = -(M + w x H(beta, Omega)),   beta' = W J^T (J W J^T)^-1 H' / h

  the beta' of least sum_i beta'_i^2 / W_i with h J beta' = H' (a larger weight: that gimbal
  does more of the work). When max |beta'_i| > beta'max the whole command is scaled down to
  the limit, keeping its direction (`scale` < 1). It records `torque_delivered`, the torque the
  command produces, -(h J beta') - w x H, so the law's wanted torque can be compared with it.
  It has no singularity handling: near a singular set J W J^T is ill-conditioned and the rates
  grow until the limit scales them (the built-in `sr` and `gsr` allocators damp instead).
- metrics `user_final_attitude_error_deg`, `user_peak_gimbal_rate_deg_s`,
  `user_rate_limit_violations`, `user_min_scale`, `user_torque_error_rel` for the checks.

Quaternions are MuJoCo's (w, x, y, z), body to world; vectors are in body axes, SI units.
"""

from dataclasses import dataclass

import numpy as np

import testbed

LAW, ALLOCATOR = "user.quaternion_pd", "user.weighted_pinv"


# --- quaternion helpers (w, x, y, z), Hamilton product ---------------------------------------

def quat_mul(p, q):
    pw, pv, qw, qv = p[0], p[1:], q[0], q[1:]
    return np.concatenate([[pw * qw - pv @ qv], pw * qv + qw * pv + np.cross(pv, qv)])


def quat_conj(q):
    return np.concatenate([q[:1], -q[1:]])


def quat_from_axis_angle(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])


def attitude_error(target, q):
    """e = 2 vec(q_T~ o q) taken the short way [rad]; |e| = 2 sin(angle / 2)."""
    q_e = quat_mul(quat_conj(target), q)
    return 2.0 * np.sign(q_e[0] or 1.0) * q_e[1:]


def angle_between_deg(p, q) -> float:
    """Rotation angle from attitude p to attitude q, in [0, 180] deg."""
    q_e = quat_mul(quat_conj(p), q)
    return float(np.degrees(2.0 * np.arctan2(np.linalg.norm(q_e[1:]), abs(q_e[0]))))


# --- the law ----------------------------------------------------------------------------------

@dataclass(kw_only=True)
class QuaternionPdParams:
    axis: list[float] = testbed.param(length=3, doc="slew axis, body axes at the start (unit vector)")
    angle_deg: float = testbed.param(ge=-180.0, le=180.0, doc="slew angle about axis")
    natural_frequency_rad_s: float = testbed.param(0.1, gt=0, doc="wn of the linearised error dynamics")
    damping_ratio: float = testbed.param(0.9, gt=0, doc="zeta of the linearised error dynamics")

    def validate(self, path: str) -> None:
        if abs(np.linalg.norm(self.axis) - 1.0) > 1e-6:
            raise testbed.InputError(f"{path}.axis", f"must be a unit vector, got {self.axis}")


@testbed.stage("law", LAW, QuaternionPdParams)
class QuaternionPd:
    outputs = ("torque", "attitude_error", "error_angle")

    def __init__(self, params: QuaternionPdParams, ctx: testbed.StageContext):
        estimator = ctx.stages["estimator"]
        if not {"quat", "omega"} <= estimator.outputs:
            raise testbed.InputError("pipeline.estimator.type", f"{LAW} needs quat and omega, estimator "
                                     f"{estimator.type!r} gives {sorted(estimator.outputs)}")
        wn, zeta = params.natural_frequency_rad_s, params.damping_ratio
        self.kp, self.kd = wn * wn, 2.0 * zeta * wn
        self.inertia = np.asarray(ctx.inertia, float)  # locked inertia at t = 0 [kg m^2]
        q0 = np.asarray(ctx.initial.quat, float)
        self.target = quat_mul(q0, quat_from_axis_angle(params.axis, np.radians(params.angle_deg)))
        self.statistics = {"target_quat": self.target}  # read by user_final_attitude_error_deg

    def torque(self, t, estimate):
        q, w = np.asarray(estimate["quat"], float), np.asarray(estimate["omega"], float)
        e = attitude_error(self.target, q)
        torque = -self.inertia @ (self.kp * e + self.kd * w) + np.cross(w, self.inertia @ w)
        return {"torque": torque, "attitude_error": e,
                "error_angle": np.array([angle_between_deg(self.target, q)])}


# --- the steering allocator -------------------------------------------------------------------

@dataclass(kw_only=True)
class WeightedPinvParams:
    beta_rate_max_deg_s: float = testbed.param(gt=0, doc="gimbal-rate limit")
    weights: list[float] = testbed.param([1.0, 1.0, 1.0, 1.0], length=4, gt=0,
                                         doc="diagonal of W: how much each gimbal is used")


@testbed.stage("allocator", ALLOCATOR, WeightedPinvParams)
class WeightedPinv:
    output = "gimbal_rates"   # the plant command this allocator produces
    outputs = ("gimbal_rates", "torque_delivered", "scale")

    def __init__(self, params: WeightedPinvParams, ctx: testbed.StageContext):
        cluster = ctx.description  # the cmg_rhombus plant describes its cluster geometry
        if not all(hasattr(cluster, a) for a in ("unit_jacobian", "momentum", "h")):
            raise testbed.InputError("pipeline.allocator.type", f"{ALLOCATOR} needs a system with a "
                                     f"gimbal cluster (model.system cmg_rhombus), got {ctx.system!r}")
        self.cluster = cluster
        self.weights = np.diag(params.weights)
        self.rate_max = np.radians(params.beta_rate_max_deg_s)
        self.statistics = {"peak_gimbal_rate": 0.0, "rate_limit_violations": 0, "min_scale": 1.0}

    def allocate(self, t, demand, estimate, actuators):
        beta, rotor = actuators["gimbal_angle"], actuators["rotor_rate"]  # encoders [rad], [rad/s]
        w = np.asarray(estimate["omega"], float)
        momentum = self.cluster.momentum(beta, rotor)                    # H [N m s], body axes
        gyroscopic = np.cross(w, momentum)
        hdot = -(np.asarray(demand["torque"], float) + gyroscopic)       # wanted H' [N m]
        J, h = self.cluster.unit_jacobian(beta), self.cluster.h          # (3, 4), [N m s]
        rates = self.weights @ J.T @ np.linalg.solve(J @ self.weights @ J.T, hdot / h)
        peak = float(np.max(np.abs(rates)))
        scale = min(1.0, self.rate_max / peak) if peak > 0 else 1.0
        rates = rates * scale                                            # keep the direction
        s = self.statistics
        s["peak_gimbal_rate"] = max(s["peak_gimbal_rate"], float(np.max(np.abs(rates))))
        s["rate_limit_violations"] += int(np.count_nonzero(np.abs(rates) > self.rate_max * (1 + 1e-12)))
        s["min_scale"] = min(s["min_scale"], scale)
        return {"gimbal_rates": rates, "torque_delivered": -h * (J @ rates) - gyroscopic,
                "scale": np.array([scale])}


# --- metrics (checked in the scenario's `checks:`) --------------------------------------------
# `uses=` names the signals a metric reads (() for the stages' own statistics): the run keeps
# only their history, so its memory does not hold every signal.

def _uses(slot: str, name: str):
    return lambda scenario: scenario.stages[slot][0] == name


@testbed.metric("user_final_attitude_error_deg", applies=_uses("law", LAW), uses=("truth/quat",))
def final_attitude_error_deg(run) -> float:
    """Angle between the final bus attitude and user.quaternion_pd's target [deg]."""
    return angle_between_deg(run.statistics["law"]["target_quat"], run.recorder["truth/quat"][-1])


@testbed.metric("user_peak_gimbal_rate_deg_s", applies=_uses("allocator", ALLOCATOR), uses=())
def peak_gimbal_rate_deg_s(run) -> float:
    """max over every control step and gimbal of user.weighted_pinv's commanded |b'_i| [deg/s]."""
    return float(np.degrees(run.statistics["allocator"]["peak_gimbal_rate"]))


@testbed.metric("user_rate_limit_violations", applies=_uses("allocator", ALLOCATOR), uses=())
def rate_limit_violations(run) -> float:
    """Count of commanded |b'_i| > b'max over every control step and gimbal (must be 0)."""
    return float(run.statistics["allocator"]["rate_limit_violations"])


@testbed.metric("user_min_scale", applies=_uses("allocator", ALLOCATOR), uses=())
def min_scale(run) -> float:
    """Smallest factor the rate limit applied to user.weighted_pinv's command (1: never limited)."""
    return float(run.statistics["allocator"]["min_scale"])


@testbed.metric("user_torque_error_rel", applies=_uses("allocator", ALLOCATOR),
                uses=("law/torque", "allocator/torque_delivered"))
def torque_error_rel(run) -> float:
    """RMS |M_wanted - M_delivered| / RMS |M_wanted| over the control samples."""
    wanted, delivered = run.recorder["law/torque"], run.recorder["allocator/torque_delivered"]
    keep = np.all(np.isfinite(wanted), axis=1) & np.all(np.isfinite(delivered), axis=1)
    wanted, delivered = wanted[keep], delivered[keep]
    return float(np.sqrt(np.mean(np.sum((wanted - delivered) ** 2, axis=1)) / np.mean(np.sum(wanted**2, axis=1))))
