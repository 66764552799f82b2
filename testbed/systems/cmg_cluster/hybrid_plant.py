"""A hybrid bus: a CMG cluster and reaction wheels on one bus (`model.wheels` of cmg_cluster).

The plant is the CMG plant with the reaction_wheels system's WheelDrive beside it: it takes
gimbal rates (and rotor speeds) and wheel torques, reads both kinds of actuator, and describes
both (`HybridBus`) for the allocator `hybrid_split` (hybrid_allocator.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.systems.cmg_cluster.cluster import ClusterGeometry
from testbed.systems.cmg_cluster.plant import CmgPlant
from testbed.systems.reaction_wheels.plant import WheelDrive
from testbed.systems.reaction_wheels.wheel_array import WheelArray


@dataclass(frozen=True)
class HybridBus:
    """What an allocator may know of a hybrid bus: the CMG cluster's geometry and the wheel array."""

    cluster: ClusterGeometry
    wheels: WheelArray


class HybridPlant(CmgPlant):
    """CmgPlant plus wheels: command `wheel_torques` (n,) [N m] beside `gimbal_rates`; truth adds
    the wheels' `wheel_rate` and `wheel_torque`, derived their `wheel_momentum` and
    `wheel_momentum_body`. The internal momentum (the bus-rotation row of the mass matrix) holds
    gimbals, rotors and wheels alike."""

    group_form = None  # its wheels are not in CmgPlant's group: a batch steps these worlds one by one

    def __init__(self, model, params, control_period: float, appendage_start=()):
        super().__init__(model, params, control_period, appendage_start)
        self.wheels = WheelDrive(model, self.data, params.wheels)  # their initial speeds are in the keyframe
        self.actuators = self.actuators | {"wheel_torques": (self.wheels.array.count,)}

    def truth(self) -> dict[str, np.ndarray]:
        return super().truth() | self.wheels.truth()

    def derived_signals(self, recorder) -> dict[str, np.ndarray]:
        return super().derived_signals(recorder) | self.wheels.derived_signals(recorder)

    def actuator_state(self) -> dict[str, np.ndarray]:
        return super().actuator_state() | {"wheel_rate": self.wheels.rates.copy()}

    def apply(self, command: dict[str, np.ndarray]) -> None:
        super().apply(command)
        torques = command.get("wheel_torques")
        if torques is not None:
            self.wheels.write_torques(*torques)

    def momentum_scale(self) -> float:
        """CmgPlant's scale, or the wheels' stored momentum or one wheel's at its speed limit when larger."""
        return max(super().momentum_scale(), self.wheels.stored_momentum(),
                   float(np.min(self.wheels.array.momentum_max)))

    def description(self) -> HybridBus:
        return HybridBus(self.geometry, self.wheels.array)

    def applied(self) -> dict:
        return super().applied() | {"model.wheels.wheel_speeds_rpm": self.wheels.speeds_rpm()}

    def scene(self) -> dict:
        """The CMG scene plus the wheels' momentum on the bus."""
        scene = super().scene()
        return scene | {"body_momenta": scene["body_momenta"] | {"truth/wheel_momentum_body": "wheel_momentum"},
                        "units": scene["units"] | {"wheel_momentum_body": "N m s", "wheel_momentum": "N m s"}}
