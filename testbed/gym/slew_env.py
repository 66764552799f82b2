"""`testbed/CmgSlew-v0` and `testbed/CmgSlewGimbalRates-v0`: bring the four-CMG bus to rest at
the slew law's target attitude (docs/stepping.md "CmgSlew-v0": spaces, reward, termination).

The scenario (default reorient_campaign: a random axis and angle per seed) names the target
through its `slew` law (`target_quat`, q0 ∘ (axis, angle)); the action replaces the law (the
body torque wanted, steered by the scenario's steering law) or the steering law itself (the
gimbal rates). The observation and action are scaled by the cluster's limits so that the plain
PD a = o_e - o_w (unit gains) is a rate-limited eigenaxis slew, critically damped at the
largest inertia (docs/stepping.md "Scaling").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import gymnasium
import numpy as np

from testbed.errors import InputError
from testbed.gym.cluster_limits import ClusterLimits, held_momenta, scaled, singularity_measures
from testbed.gym.stepped_env import SteppedEnv, norms
from testbed.math.quaternion import quat_conj, quat_mul, rotation_vector
from testbed.math.validation import positive_number

# the reward's weights: attitude error, body rate, effort (each term at most 1 per component)
ATTITUDE_WEIGHT, RATE_WEIGHT, EFFORT_WEIGHT = 1.0, 0.1, 0.01
# The time limit's default settling allowance, in units of 1/omega_n of the unit PD's linear
# region: a critically damped error falls as (1 + x) e^-x, x = omega_n t, to 1e-4 of e_s at x = 11.6.
SETTLING_TIMES = 15.0


def rotation_to(quat, target_quat) -> np.ndarray:
    """e (..., 3): the rotation vector taking the body at `quat` (..., 4) to `target_quat`, body axes [rad]."""
    return rotation_vector(quat_mul(quat_conj(quat), target_quat))


def attitude_observation(quat, omega, target_quat, error_scale: float, rate_scale: float) -> np.ndarray:
    """[e / e_s with its norm held to 1 (its direction kept), omega / omega_s] (..., 6): e the
    rotation vector taking the body to the target, body axes [rad], omega the body rate
    [rad/s] (quat, target_quat (..., 4), omega (..., 3)); e_s [rad] and omega_s [rad/s] the
    scales (`SlewScales`)."""
    error = rotation_to(quat, target_quat) / error_scale
    norm = norms(error)[..., None]
    return np.concatenate([error / np.maximum(norm, 1.0), np.asarray(omega, dtype=np.float64) / rate_scale], axis=-1)


@dataclass(frozen=True)
class SlewScales:
    """The scales of CmgSlew's spaces (docs/stepping.md "Scaling"), from the cluster's limits:

    torque tau_s = rate_max S_min [N m], the most torque the cluster gives along its weakest
    axis (the action's unit); rate omega_s = f S_min / J_max [rad/s], the body rate whose
    momentum the cluster holds along any axis with the margin 1 - f (the rate observation's
    unit, and the cruise rate of the unit PD); error e_s = 4 J_max omega_s^2 / tau_s [rad], at
    which the PD a = e/e_s - omega/omega_s is critically damped on the largest inertia
    (J e'' + (tau_s/omega_s) e' + (tau_s/e_s) e = 0: omega_n = tau_s / (2 J_max omega_s))."""

    torque: float
    rate: float
    error: float
    natural_frequency: float

    @classmethod
    def of(cls, limits: ClusterLimits, momentum_fraction: float) -> "SlewScales":
        torque = limits.torque_everywhere
        rate = momentum_fraction * limits.least_momentum / limits.inertia_max
        return cls(torque, rate, 4.0 * limits.inertia_max * rate**2 / torque,
                   torque / (2.0 * limits.inertia_max * rate))

    def time_limit(self, angle: float, settling_times: float = SETTLING_TIMES) -> float:
        """[s] of a slew by `angle` [rad]: the cruise at omega_s, then `settling_times` / omega_n."""
        return angle / self.rate + settling_times / self.natural_frequency


class CmgSlewEnv(SteppedEnv):
    """A slew of the four-CMG bus to rest at the target.

    action "torque": a in [-1, 1]^3, the body torque wanted a * tau_s (`SlewScales`), steered
    by the scenario's steering law; "gimbal_rates": a in [-1, 1]^n, the gimbal rates
    a * rate_max [rad/s] straight to the gimbal servos.
    observation (12 + 2n,): the attitude error and body rate in the scales (`attitude_observation`;
    the rate within +-max_rate / omega_s), sin and cos of the n gimbal angles, the cluster's
    momentum / (n h) and the attitude error / pi (body axes), these in [-1, 1].
    reward per control period: -(|e|/pi)^2 - 0.1 |omega / max_rate|^2 - 0.01 |a|^2 / dim(a).
    terminated: done when |e| <= tolerance_deg and |omega| <= rate_tolerance_deg_s; failed when
    a body rate component passes max_rate_deg_s, the run diverges or, with singular_measure_min
    given, the gimbals reach a singular set (cost: 1.31 a period left).
    truncated: at the episode's time limit, `SlewScales.time_limit` of its slew angle with
    `settling_times`, or the scenario's end if sooner (the default overrides make the run long
    enough for any angle)."""

    failure_cost_per_period = ATTITUDE_WEIGHT + 3 * RATE_WEIGHT + EFFORT_WEIGHT

    def __init__(self, scenario="reorient_campaign", overrides=("sim.duration_s=300",), action: str = "torque",
                 tolerance_deg: float = 0.01, rate_tolerance_deg_s: float = 0.002, max_rate_deg_s: float = 6.0,
                 momentum_fraction: float = 0.6, settling_times: float = SETTLING_TIMES,
                 singular_measure_min: float | None = None,
                 render_mode: str | None = None, rrd_path=None):
        if action not in ("torque", "gimbal_rates"):
            raise InputError("action", f"must be 'torque' or 'gimbal_rates', got {action!r}")
        for name, value in (("tolerance_deg", tolerance_deg), ("rate_tolerance_deg_s", rate_tolerance_deg_s),
                            ("max_rate_deg_s", max_rate_deg_s), ("settling_times", settling_times)):
            positive_number(name, value)
        if not 0 < momentum_fraction < 1:
            raise InputError("momentum_fraction", f"must be in (0, 1), got {momentum_fraction!r}")
        super().__init__(scenario, overrides, render_mode, rrd_path)
        if "target_quat" not in self.sim.pipeline.statistics().get("law", {}):
            raise InputError("pipeline.law.type", "CmgSlew needs a law that declares its target (e.g. slew), "
                                                  f"not {self.sim.scenario.stages['law'][0]}")
        self.action = action
        self.limits = ClusterLimits.of(self.sim)
        self.scales = SlewScales.of(self.limits, momentum_fraction)
        self.tolerance = math.radians(tolerance_deg)
        self.rate_tolerance = math.radians(rate_tolerance_deg_s)
        self.max_rate = math.radians(max_rate_deg_s)
        self.singular_measure_min = singular_measure_min
        self.settling_times = settling_times
        n = self.limits.gimbals
        self.action_space = gymnasium.spaces.Box(-1.0, 1.0, (3 if action == "torque" else n,), np.float64)
        rate_bound = self.max_rate / self.scales.rate
        high = np.concatenate([np.ones(3), np.full(3, rate_bound), np.ones(2 * n + 6)])
        self.observation_space = gymnasium.spaces.Box(-high, high, dtype=np.float64)
        self.episode = self.episode_of(self.sim.plan)

    @property
    def target(self) -> np.ndarray:
        """The episode's target attitude (w, x, y, z), body to world."""
        return self.episode["target"]

    def episode_of(self, plan):
        return {"target": np.asarray(plan.pipeline.law.statistics["target_quat"], dtype=np.float64)}

    def time_limit_ticks(self, plan, episode):
        angle = float(norms(rotation_to(plan.plant.quat(), episode["target"])))
        return math.ceil(self.scales.time_limit(angle, self.settling_times) / self.control_period_s)

    def commands(self, actions):
        if self.action == "torque":
            return {"law": {"torque": actions * self.scales.torque}}
        return {"allocator": {"gimbal_rates": actions * self.limits.gimbal_rate_max}}

    def read(self, plants):
        read = [plant.actuator_state() for plant in plants]
        actuators = {key: np.array([values[key] for values in read], dtype=np.float64) for key in read[0]}
        beta = actuators["gimbal_angle"]
        return {"quat": np.array([plant.quat() for plant in plants]), "omega": np.array([plant.omega() for plant in plants]),
                "gimbal_angle": beta, "internal_momentum": held_momenta(plants, actuators),
                "singularity_measure": singularity_measures(plants, beta)}

    def observations(self, state, episodes):
        quat, target = state["quat"], episodes["target"]
        attitude = attitude_observation(quat, state["omega"], target, self.scales.error, self.scales.rate)
        beta = state["gimbal_angle"]
        return np.concatenate([np.clip(attitude, self.observation_space.low[:6], self.observation_space.high[:6]),
                               np.sin(beta), np.cos(beta),
                               scaled(state["internal_momentum"], self.limits.momentum_max),
                               rotation_to(quat, target) / math.pi], axis=-1)

    def _errors(self, state, episodes) -> tuple[np.ndarray, np.ndarray]:
        """(attitude error angle [rad], body rate norm [rad/s]) (N,) now."""
        return norms(rotation_to(state["quat"], episodes["target"])), norms(state["omega"])

    def rewards(self, state, episodes, actions):
        angle, _ = self._errors(state, episodes)
        rate = scaled(state["omega"], self.max_rate)
        return -(ATTITUDE_WEIGHT * (angle / math.pi) ** 2 + RATE_WEIGHT * np.sum(rate * rate, axis=-1)
                 + EFFORT_WEIGHT * np.sum(actions * actions, axis=-1) / actions.shape[-1])

    def outcomes(self, state, episodes):
        angle, rate = self._errors(state, episodes)
        failed = np.any(np.abs(state["omega"]) > self.max_rate, axis=-1)
        if self.singular_measure_min is not None:
            failed = failed | (state["singularity_measure"] < self.singular_measure_min)
        return (angle <= self.tolerance) & (rate <= self.rate_tolerance), failed

    def details(self, state, episodes):
        angle, rate = self._errors(state, episodes)
        return {"attitude_error_deg": np.degrees(angle), "rate_deg_s": np.degrees(rate),
                "singularity_measure": state["singularity_measure"]}
