"""The limits of the CMG cluster an environment's spaces are scaled by: the gimbal-rate limit of
the scenario's steering law, the momentum the cluster holds along its weakest axis, the torque
it gives there, and the spacecraft's largest principal inertia (docs/stepping.md "Scaling")."""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

from testbed.errors import InputError
from testbed.pipeline import stage_info
from testbed.systems.cmg_cluster.momentum_gauge import support_extremes


@dataclass(frozen=True)
class ClusterLimits:
    """gimbals: how many; rotor_momentum [N m s] each; gimbal_rate_max [rad/s]: the steering
    law's limit. `torque_max` = gimbals h rate_max [N m] bounds the torque the cluster can give
    at that limit along any axis (each gimbal gives at most h rate_max: the rhombus-cluster
    reorientation paper's eq. 17-18, docs/theory/papers.md). least_momentum [N m s]: min over
    directions u of the most momentum the cluster holds along u, S(u) = sum_i h_i |u x g_i|
    (docs/theory/momentum-envelope.md); inertia_max [kg m^2]: the largest principal moment of
    the spacecraft with its gimbals locked."""

    gimbals: int
    rotor_momentum: float
    gimbal_rate_max: float
    least_momentum: float
    inertia_max: float

    @property
    def torque_max(self) -> float:
        return self.gimbals * self.rotor_momentum * self.gimbal_rate_max

    @property
    def torque_everywhere(self) -> float:
        """rate_max S_min [N m]: the most torque the cluster gives along its weakest axis (the
        torques at gimbal rates up to rate_max are rate_max times the momentum set)."""
        return self.gimbal_rate_max * self.least_momentum

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
        cluster = plant.description()
        (least, _), _ = support_extremes(cluster.gimbal_axes, cluster.rotor_momentum)
        return cls(plant.actuators["gimbal_rates"][0], float(scenario.model.rotor_momentum_nms), float(limit),
                   least, float(np.linalg.eigvalsh(plant.locked_inertia()).max()))


def singularity_measures(plants: list, gimbal_angles: np.ndarray) -> np.ndarray:
    """(N,) sqrt(det(J J^T)) of each plant's cluster's unit Jacobian at its row of gimbal angles
    (N, n) [rad] (0: singular): each world's own cluster (a campaign may disperse its geometry),
    the worlds of one geometry in one call on their rows."""
    measures = np.empty(len(plants))
    for cluster, rows in _alike(plants):
        measures[rows] = cluster.singularity_measure(np.asarray(gimbal_angles)[rows])
    return measures


def held_momenta(plants: list, actuators: dict) -> np.ndarray:
    """(N, 3) the momentum each plant's cluster holds relative to the bus [N m s], bus frame, from
    its read-outs `actuators` (gimbal_angle, rotor_rate, gimbal_rate: (N, n) each):
    ClusterGeometry.held_momentum, what MuJoCo's mass matrix gives (Plant.internal_momentum_body)
    to 3e-13 of it on the slew environment's bus, at a tenth of its cost a world."""
    momenta = np.empty((len(plants), 3))
    for cluster, rows in _alike(plants):
        momenta[rows] = cluster.held_momentum(*(np.asarray(actuators[key])[rows]
                                                for key in ("gimbal_angle", "rotor_rate", "gimbal_rate")))
    return momenta


# plant -> its cluster's geometry as bytes, read once a plant (a plant's cluster does not change)
_geometry_keys: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def _alike(plants: list) -> list:
    """[(cluster, rows)]: the plants' clusters (their `description()`), the rows of each geometry
    together (a campaign may disperse it)."""
    alike: dict[bytes, list[int]] = {}
    for row, plant in enumerate(plants):
        key = _geometry_keys.get(plant)
        if key is None:
            cluster = plant.description()
            key = _geometry_keys[plant] = b"".join(np.asarray(value).tobytes() for value in (
                cluster.gimbal_axes, cluster.spin_axes_zero, cluster.rotor_momentum, cluster.spin_inertia,
                cluster.gimbal_axis_inertia))
        alike.setdefault(key, []).append(row)
    return [(plants[rows[0]].description(), rows) for rows in alike.values()]


def scaled(values, scale) -> np.ndarray:
    """values / scale clipped to [-1, 1], NaN as 0 (a state that blew up ends the episode)."""
    return np.clip(np.nan_to_num(np.asarray(values, dtype=np.float64) / scale), -1.0, 1.0)
