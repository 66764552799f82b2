"""The limits of the four-CMG cluster an environment's spaces are scaled by: the gimbal-rate
limit of the scenario's steering law and the torque envelope it bounds."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.errors import InputError
from testbed.pipeline import stage_info


@dataclass(frozen=True)
class ClusterLimits:
    """gimbals: how many; rotor_momentum [N m s] each; gimbal_rate_max [rad/s]: the steering
    law's limit. `torque_max` = gimbals h rate_max [N m] bounds the torque the cluster can give
    at that limit along any axis (each gimbal gives at most h rate_max: the rhombus-cluster
    reorientation paper's eq. 17-18, docs/theory/papers.md)."""

    gimbals: int
    rotor_momentum: float
    gimbal_rate_max: float

    @property
    def torque_max(self) -> float:
        return self.gimbals * self.rotor_momentum * self.gimbal_rate_max

    @property
    def momentum_max(self) -> float:
        """The most momentum the cluster holds, all rotors aligned [N m s]."""
        return self.gimbals * self.rotor_momentum

    @classmethod
    def of(cls, sim) -> "ClusterLimits":
        """The limits of a Simulation's scenario: a CMG cluster steered by a rate-limited law."""
        scenario, plant = sim.scenario, sim.plant
        if "gimbal_rates" not in plant.actuators or not hasattr(plant.description(), "singularity_measure"):
            raise InputError("model.system", f"the environment needs a CMG cluster, not {scenario.system}")
        limit = stage_info("allocator", *scenario.stages["allocator"]).design.get("gimbal_rate_limit")
        if limit is None:
            raise InputError("pipeline.allocator.type", f"the environment needs a steering law with a gimbal-rate "
                                                        f"limit, not {scenario.stages['allocator'][0]}")
        return cls(plant.actuators["gimbal_rates"][0], float(scenario.model.rotor_momentum_nms), float(limit))


def singularity_measure(sim) -> float:
    """sqrt(det(J J^T)) of the cluster's unit Jacobian at the gimbal angles now (0: singular)."""
    return float(sim.plant.description().singularity_measure(sim.plant.actuator_state()["gimbal_angle"]))


def scaled(values, scale) -> np.ndarray:
    """values / scale clipped to [-1, 1], NaN as 0 (a state that blew up ends the episode)."""
    return np.clip(np.nan_to_num(np.asarray(values, dtype=np.float64) / scale), -1.0, 1.0)
