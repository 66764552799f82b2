"""`testbed/CmgSlew-v0` and `testbed/CmgSlewGimbalRates-v0`: bring the four-CMG bus to rest at
the slew law's target attitude (docs/stepping.md "CmgSlew-v0": spaces, reward, termination).

The scenario (default reorient_campaign: a random axis and angle per seed) names the target
through its `slew` law (`target_quat`, q0 ∘ (axis, angle)); the action replaces the law (the
body torque wanted, steered by the scenario's steering law) or the steering law itself (the
gimbal rates).
"""

from __future__ import annotations

import math

import gymnasium
import numpy as np

from testbed.errors import InputError
from testbed.gym.cluster_limits import ClusterLimits, scaled, singularity_measure
from testbed.gym.stepped_env import SteppedEnv
from testbed.math.quaternion import quat_conj, quat_mul, rotation_vector

# the reward's weights: attitude error, body rate, effort (each term at most 1 per component)
ATTITUDE_WEIGHT, RATE_WEIGHT, EFFORT_WEIGHT = 1.0, 0.1, 0.01


def attitude_observation(quat, omega, target_quat, max_rate: float) -> np.ndarray:
    """[e / pi, omega / max_rate] (6,): e = the rotation vector taking the body to the target,
    body axes [rad] (|e| <= pi), omega the body rate [rad/s], clipped to [-1, 1]."""
    error = rotation_vector(quat_mul(quat_conj(quat), target_quat))
    return np.concatenate([error / math.pi, scaled(omega, max_rate)])


class CmgSlewEnv(SteppedEnv):
    """A slew of the four-CMG bus to rest at the target.

    action "torque": a in [-1, 1]^3, the body torque wanted a * torque_max (torque_max =
    n h rate_max, `ClusterLimits`), steered by the scenario's steering law; "gimbal_rates":
    a in [-1, 1]^n, the gimbal rates a * rate_max [rad/s] straight to the gimbal servos.
    observation (17,) in [-1, 1]: the attitude error and body rate (`attitude_observation`),
    sin and cos of the n gimbal angles, the cluster's momentum / (n h) (body axes).
    reward per control period: -(|e|/pi)^2 - 0.1 |omega / max_rate|^2 - 0.01 |a|^2 / dim(a).
    terminated: done when |e| <= tolerance_deg and |omega| <= rate_tolerance_deg_s; failed when
    a body rate component passes max_rate_deg_s, the gimbals reach a singular set (measure below
    singular_measure_min) or the run diverges (cost: 1.31 a period left).
    truncated: at the scenario's duration."""

    failure_cost_per_period = ATTITUDE_WEIGHT + 3 * RATE_WEIGHT + EFFORT_WEIGHT

    def __init__(self, scenario="reorient_campaign", overrides=(), action: str = "torque",
                 tolerance_deg: float = 0.01, rate_tolerance_deg_s: float = 0.002, max_rate_deg_s: float = 6.0,
                 singular_measure_min: float = 0.05, render_mode: str | None = None, rrd_path=None):
        if action not in ("torque", "gimbal_rates"):
            raise InputError("action", f"must be 'torque' or 'gimbal_rates', got {action!r}")
        for name, value in (("tolerance_deg", tolerance_deg), ("rate_tolerance_deg_s", rate_tolerance_deg_s),
                            ("max_rate_deg_s", max_rate_deg_s)):
            if not value > 0:
                raise InputError(name, f"must be > 0, got {value!r}")
        super().__init__(scenario, overrides, render_mode, rrd_path)
        if "target_quat" not in self.sim.pipeline.statistics().get("law", {}):
            raise InputError("pipeline.law.type", "CmgSlew needs a law that declares its target (e.g. slew), "
                                                  f"not {self.sim.scenario.stages['law'][0]}")
        self.action = action
        self.limits = ClusterLimits.of(self.sim)
        self.tolerance = math.radians(tolerance_deg)
        self.rate_tolerance = math.radians(rate_tolerance_deg_s)
        self.max_rate = math.radians(max_rate_deg_s)
        self.singular_measure_min = singular_measure_min
        n = self.limits.gimbals
        self.action_space = gymnasium.spaces.Box(-1.0, 1.0, (3 if action == "torque" else n,), np.float64)
        self.observation_space = gymnasium.spaces.Box(-1.0, 1.0, (9 + 2 * n,), np.float64)
        self.episode_started()

    def episode_started(self) -> None:
        self.target = np.asarray(self.sim.pipeline.law.statistics["target_quat"], dtype=np.float64)

    def command(self, action):
        if self.action == "torque":
            return {"law": {"torque": action * self.limits.torque_max}}
        return {"allocator": {"gimbal_rates": action * self.limits.gimbal_rate_max}}

    def observation(self):
        plant = self.sim.plant
        beta = np.asarray(plant.actuator_state()["gimbal_angle"], dtype=np.float64)
        return np.concatenate([attitude_observation(plant.quat(), plant.omega(), self.target, self.max_rate),
                               np.sin(beta), np.cos(beta),
                               scaled(plant.internal_momentum_body(), self.limits.momentum_max)])

    def _errors(self) -> tuple[float, float]:
        """(attitude error angle [rad], body rate norm [rad/s]) now."""
        plant = self.sim.plant
        return (float(np.linalg.norm(rotation_vector(quat_mul(quat_conj(plant.quat()), self.target)))),
                float(np.linalg.norm(plant.omega())))

    def reward(self, action):
        angle, _ = self._errors()
        rate = scaled(self.sim.plant.omega(), self.max_rate)
        return -(ATTITUDE_WEIGHT * (angle / math.pi) ** 2 + RATE_WEIGHT * float(rate @ rate)
                 + EFFORT_WEIGHT * float(action @ action) / action.size)

    def outcome(self):
        angle, rate = self._errors()
        failed = (bool(np.any(np.abs(self.sim.plant.omega()) > self.max_rate))
                  or singularity_measure(self.sim) < self.singular_measure_min)
        return angle <= self.tolerance and rate <= self.rate_tolerance, failed

    def details(self):
        angle, rate = self._errors()
        return {"attitude_error_deg": math.degrees(angle), "rate_deg_s": math.degrees(rate),
                "singularity_measure": singularity_measure(self.sim)}
