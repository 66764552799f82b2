"""A classical slew controller, written once as a policy on CmgSlew-v0's observation and
registered as a plug-in law (`examples.slew_pd`) that computes the same observation from its
estimate: the same numbers either way (examples/gym_slew_classical.py checks it).

The policy is the plain PD a = kp o_e - kd o_w on the observation's scaled attitude error o_e
(its norm held to 1) and body rate o_w. With unit gains the environment's scaling makes it a
rate-limited eigenaxis slew: far from the target o_e is a unit vector and the rate settles at
o_w = o_e, the cruise rate omega_s; near it the loop is critically damped on the largest
inertia (docs/stepping.md "Scaling").
"""

from dataclasses import dataclass

import numpy as np

import testbed
from testbed.gym.slew_env import attitude_observation


class PlainPD:
    """action(observation) of CmgSlew-v0 (torque action): clip(kp o_e - kd o_w, -1, 1), o_e and
    o_w the observation's first and second three entries."""

    def __init__(self, kp: float = 1.0, kd: float = 1.0):
        self.kp, self.kd = kp, kd

    def __call__(self, observation):
        return np.clip(self.kp * observation[0:3] - self.kd * observation[3:6], -1.0, 1.0)


@dataclass(kw_only=True)
class SlewPDParams:
    target_quat: list[float] = testbed.param(length=4, doc="the attitude to reach (w, x, y, z), body to world")
    error_scale_rad: float = testbed.param(gt=0, doc="the observation's attitude-error scale e_s")
    rate_scale_rad_s: float = testbed.param(gt=0, doc="the observation's body-rate scale omega_s")
    torque_scale_nm: float = testbed.param(gt=0, doc="the action's torque scale tau_s")


@testbed.stage("law", "examples.slew_pd", SlewPDParams)
class SlewPD:
    """The policy as a law: the observation's attitude part from the estimate, then the policy."""

    outputs = ("torque",)

    def __init__(self, params, ctx):
        self.target = np.asarray(params.target_quat, dtype=np.float64)
        self.scales = params.error_scale_rad, params.rate_scale_rad_s
        self.torque_scale = params.torque_scale_nm
        self.policy = PlainPD()

    def torque(self, t, estimate):
        observation = attitude_observation(estimate["quat"], estimate["omega"], self.target, *self.scales)
        return {"torque": self.policy(observation) * self.torque_scale}
