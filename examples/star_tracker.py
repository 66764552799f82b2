"""A user's star tracker as a plug-in sensor (examples/star_tracker.yaml).

Sensor `user.star_tracker`: the attitude it reports is `latency_ticks` control ticks old (an
image is exposed, then processed) with white noise, plus a 3-axis rate gyro with no latency:

    quat(t_k)  = q(t_(k-N)) o exp(dtheta / 2),  dtheta ~ N(0, attitude_noise_rad^2 I)  (body axes)
    omega(t_k) = w(t_k) + N(0, rate_noise_rad_s^2 I)                                    [rad/s]

Before N ticks have passed it repeats the first image, q(0). The noise is seeded: the same
seed gives the same samples bit for bit. It declares `outputs = ("quat", "omega")`, which the
built-in `attitude` estimator and `slew` law require of their predecessor.

The built-in metric `max_tracking_error_deg` is the error the law sees (program vs measured
attitude); with a late sensor the true error is larger, so the plug-in adds the metric
`user_true_tracking_error_deg`: program attitude vs the true attitude, from the trace.

Written against the public API only (`import testbed`); quaternions are MuJoCo's (w, x, y, z),
body to world.
"""

from collections import deque
from dataclasses import dataclass

import numpy as np

import testbed


def quat_mul(p, q):
    """Hamilton product p o q of (4,) or (n, 4) arrays."""
    pw, pv, qw, qv = p[..., :1], p[..., 1:], q[..., :1], q[..., 1:]
    w = pw * qw - np.sum(pv * qv, axis=-1, keepdims=True)
    return np.concatenate([w, pw * qv + qw * pv + np.cross(pv, qv)], axis=-1)


def quat_conj(q):
    return np.concatenate([q[..., :1], -q[..., 1:]], axis=-1)


def quat_exp_half(theta):
    """exp(theta / 2): the unit quaternion of rotation vector theta [rad]."""
    angle = float(np.linalg.norm(theta))
    if angle == 0.0:
        return np.array([1.0, 0.0, 0.0, 0.0])
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * theta / angle])


@dataclass(kw_only=True)
class StarTrackerParams:
    latency_ticks: int = testbed.param(2, ge=0, doc="age of the attitude, in control periods")
    attitude_noise_rad: float = testbed.param(0.0, ge=0, doc="std of each small-angle error component")
    rate_noise_rad_s: float = testbed.param(0.0, ge=0, doc="gyro white noise, std per axis and sample")
    seed: int = testbed.param(0, ge=0, doc="noise seed")


@testbed.stage("sensor", "user.star_tracker", StarTrackerParams)
class StarTracker:
    outputs = ("quat", "omega")

    def __init__(self, params: StarTrackerParams, ctx: testbed.StageContext):
        self.params = params
        self.images = deque(maxlen=params.latency_ticks + 1)  # the last N + 1 true attitudes
        self.rng = np.random.default_rng(params.seed)
        self.latency_s = params.latency_ticks * ctx.control_period

    def measure(self, t, plant):
        p = self.params
        self.images.append(np.array(plant.quat(), float))   # called once per control tick
        quat = self.images[0]                                # N ticks old (or the first image)
        if p.attitude_noise_rad:
            quat = quat_mul(quat, quat_exp_half(p.attitude_noise_rad * self.rng.standard_normal(3)))
        omega = np.array(plant.omega(), float)
        if p.rate_noise_rad_s:
            omega = omega + p.rate_noise_rad_s * self.rng.standard_normal(3)
        return {"quat": quat, "omega": omega}


def _slew_with_star_tracker(scenario) -> bool:
    return scenario.stages["sensor"][0] == "user.star_tracker" and scenario.stages["law"][0] == "slew"


@testbed.metric("user_true_tracking_error_deg", applies=_slew_with_star_tracker,
                uses=("law/program_quat", "truth/quat"))  # the run keeps only these signals' history
def true_tracking_error_deg(run) -> float:
    """max over control samples of the angle between the slew's program attitude and the TRUE attitude [deg]."""
    program, truth = run.recorder["law/program_quat"], run.recorder["truth/quat"]
    keep = np.all(np.isfinite(program), axis=1)          # the last row holds only the truth
    error = quat_mul(quat_conj(program[keep]), truth[keep])
    return float(np.degrees(np.max(2.0 * np.arctan2(np.linalg.norm(error[:, 1:], axis=1), np.abs(error[:, 0])))))
