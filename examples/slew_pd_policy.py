"""A classical slew controller, written once as a policy on CmgSlew-v0's observation and
registered as a plug-in law (`examples.slew_pd`) that computes the same observation from its
estimate: the same numbers either way (examples/gym_slew_classical.py checks it).

The policy is a rate-limited quaternion PD: the wanted body rate k e, its norm held to
w_max, tracked by the torque J k_w (w_ref - w) on a scalar inertia J (e: the rotation vector
to the target, from the observation), the torque scaled to the action space [-1, 1]^3.
"""

from dataclasses import dataclass

import numpy as np

import testbed
from testbed.gym.slew_env import attitude_observation


class RateLimitedPD:
    """action(observation) of CmgSlew-v0 (torque action): its first six entries are the
    attitude error / pi and the body rate / max_rate."""

    def __init__(self, max_rate, torque_max, inertia=1000.0, k=0.4, k_w=1.0, w_max=0.03):
        self.max_rate, self.torque_max = max_rate, torque_max
        self.inertia, self.k, self.k_w, self.w_max = inertia, k, k_w, w_max

    def __call__(self, observation):
        error, omega = observation[0:3] * np.pi, observation[3:6] * self.max_rate
        wanted = self.k * error
        speed = float(np.linalg.norm(wanted))
        if speed > self.w_max:
            wanted = wanted * (self.w_max / speed)
        torque = self.inertia * self.k_w * (wanted - omega)
        return np.clip(torque / self.torque_max, -1.0, 1.0)


@dataclass(kw_only=True)
class SlewPDParams:
    target_quat: list[float] = testbed.param(length=4, doc="the attitude to reach (w, x, y, z), body to world")
    max_rate_rad_s: float = testbed.param(gt=0, doc="the observation's body-rate scale")
    torque_max_nm: float = testbed.param(gt=0, doc="the action's torque scale")


@testbed.stage("law", "examples.slew_pd", SlewPDParams)
class SlewPD:
    """The policy as a law: the observation's attitude part from the estimate, then the policy."""

    outputs = ("torque",)

    def __init__(self, params, ctx):
        self.target = np.asarray(params.target_quat, dtype=np.float64)
        self.max_rate, self.torque_max = params.max_rate_rad_s, params.torque_max_nm
        self.policy = RateLimitedPD(self.max_rate, self.torque_max)

    def torque(self, t, estimate):
        observation = attitude_observation(estimate["quat"], estimate["omega"], self.target, self.max_rate)
        return {"torque": self.policy(observation) * self.torque_max}
