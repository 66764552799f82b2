"""`testbed/CmgSpinUp-v0`: spin the four-CMG bus up to Omega about its major axis z, seeing only
what the single rate gyro gives (Lebedev 1976's task 1; docs/stepping.md "CmgSpinUp-v0").

The scenario (default lebedev_spinup_cmg) names the gyro (its `rate_gyro` sensor) and the
wanted spin (its `lebedev` law's `spin_rate_deg_s`); the action replaces the law, and the
scenario's steering turns the torque into gimbal rates.
"""

from __future__ import annotations

import math

import gymnasium
import numpy as np

from testbed.errors import InputError
from testbed.gym.cluster_limits import ClusterLimits, scaled, singularity_measures
from testbed.gym.stepped_env import SteppedEnv, norms
from testbed.pipeline import stage_info

EFFORT_WEIGHT = 0.01


class CmgSpinUpEnv(SteppedEnv):
    """The one-gyro spin-up.

    action: a in [-1, 1]^3, the body torque wanted a * torque_max (`ClusterLimits`), steered by
    the scenario's steering law. observation (1,): what the rate gyro reads at the start of the
    next period, noise-free, y = p . omega (p its sensing axis) / max_rate, clipped to [-1, 1]
    (the scenario's own gyro, with its noise, still feeds the pipeline's estimator).
    reward per control period (from the truth, which the agent does not see):
    -min(|omega - Omega e_z| / Omega, 1)^2 - 0.01 |a|^2 / 3.
    terminated: done when |omega - Omega e_z| <= tolerance_deg_s; failed when a body rate
    component passes max_rate_deg_s, the gimbals reach a singular set (measure below
    singular_measure_min) or the run diverges (cost: 1.01 a period left).
    truncated: at the scenario's duration."""

    failure_cost_per_period = 1.0 + EFFORT_WEIGHT

    def __init__(self, scenario="lebedev_spinup_cmg", overrides=(), tolerance_deg_s: float = 1e-3,
                 max_rate_deg_s: float = 5.0, singular_measure_min: float = 0.05,
                 render_mode: str | None = None, rrd_path=None):
        for name, value in (("tolerance_deg_s", tolerance_deg_s), ("max_rate_deg_s", max_rate_deg_s)):
            if not value > 0:
                raise InputError(name, f"must be > 0, got {value!r}")
        super().__init__(scenario, overrides, render_mode, rrd_path)
        scenario = self.sim.scenario
        axis = stage_info("sensor", *scenario.stages["sensor"]).design.get("sensing_axis")
        if axis is None:
            raise InputError("pipeline.sensor.type", f"CmgSpinUp needs a single rate gyro (rate_gyro), "
                                                     f"not {scenario.stages['sensor'][0]}")
        self.sensing_axis = np.asarray(axis, dtype=np.float64)
        spin = getattr(scenario.stages["law"][1], "spin_rate_deg_s", None)
        if not spin:
            raise InputError("pipeline.law.spin_rate_deg_s", "CmgSpinUp needs the wanted spin (a lebedev law "
                                                             "with task spin)")
        self.spin = np.array([0.0, 0.0, math.radians(spin)])
        self.limits = ClusterLimits.of(self.sim)
        self.tolerance = math.radians(tolerance_deg_s)
        self.max_rate = math.radians(max_rate_deg_s)
        self.singular_measure_min = singular_measure_min
        self.action_space = gymnasium.spaces.Box(-1.0, 1.0, (3,), np.float64)
        self.observation_space = gymnasium.spaces.Box(-1.0, 1.0, (1,), np.float64)

    def commands(self, actions):
        return {"law": {"torque": actions * self.limits.torque_max}}

    def read(self, plants):
        beta = np.array([plant.actuator_state()["gimbal_angle"] for plant in plants], dtype=np.float64)
        return {"omega": np.array([plant.omega() for plant in plants]),
                "singularity_measure": singularity_measures(plants, beta)}

    def observations(self, state, episodes):
        return scaled(np.sum(state["omega"] * self.sensing_axis, axis=-1, keepdims=True), self.max_rate)

    def _spin_error(self, state) -> np.ndarray:
        """|omega - Omega e_z| (N,) [rad/s]."""
        return norms(state["omega"] - self.spin)

    def rewards(self, state, episodes, actions):
        return -(np.minimum(self._spin_error(state) / self.spin[2], 1.0) ** 2
                 + EFFORT_WEIGHT * np.sum(actions * actions, axis=-1) / 3)

    def outcomes(self, state, episodes):
        failed = (np.any(np.abs(state["omega"]) > self.max_rate, axis=-1)
                  | (state["singularity_measure"] < self.singular_measure_min))
        return self._spin_error(state) <= self.tolerance, failed

    def details(self, state, episodes):
        return {"spin_error_deg_s": np.degrees(self._spin_error(state)),
                "singularity_measure": state["singularity_measure"]}
