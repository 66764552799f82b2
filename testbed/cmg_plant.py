"""The 4-CMG spacecraft as a plant: gimbal-rate servos and ideal torques, cluster read-outs."""

from __future__ import annotations

import numpy as np

from testbed.domains.cmg_rhombus import CmgRhombus
from testbed.plant import Plant


class CmgPlant(Plant):
    """Truth adds gimbal angles and rates, rotor rates and the cluster momentum H (body frame)."""

    actuators = ("body_torque", "gimbal_rates")

    def __init__(self, model):
        super().__init__(CmgRhombus(model))
        self.geometry = self.domain.geometry

    def initialise(self, initial) -> None:
        self.domain.initialise(self.data, initial.omega, initial.quat)

    def truth(self) -> dict[str, np.ndarray]:
        signals = super().truth()
        signals.update(gimbal_angle=self.domain.gimbal_angles(self.data),
                       gimbal_rate=self.domain.gimbal_rates(self.data),
                       rotor_rate=self.domain.rotor_rates(self.data))
        return signals

    def derived_signals(self, recorder) -> dict[str, np.ndarray]:
        """Cluster spin momentum H(beta, Omega), body axes, from the recorded gimbal and rotor
        histories (SEEDS §004 eq. 15), computed after the run in one vectorised pass."""
        return {"truth/cmg_momentum": self.geometry.momentum(recorder["truth/gimbal_angle"],
                                                            recorder["truth/rotor_rate"])}

    def actuator_state(self) -> dict[str, np.ndarray]:
        """What the gimbal encoders and rotor tachometers report."""
        return {"gimbal_angle": self.domain.gimbal_angles(self.data),
                "rotor_rate": self.domain.rotor_rates(self.data)}

    def apply(self, command: dict[str, np.ndarray]) -> None:
        super().apply(command)
        rates = command.get("gimbal_rates")
        if rates is not None:
            self.domain.set_gimbal_rate_command(self.data, rates)

    def internal_momentum_body(self) -> np.ndarray:
        return self.domain.internal_momentum_body(self.data)

    def momentum_scale(self) -> float:
        """max(|L|, |H|, sum_i |h_i|): the stored rotor momentum sum_i Js_i |Omega_i| keeps the
        scale meaningful for a zero-momentum gimbal set (H = 0, e.g. (45, -45, -45, 45) deg)."""
        stored = float(np.sum(self.geometry.spin_inertia * np.abs(self.domain.rotor_rates(self.data))))
        return max(super().momentum_scale(), stored)

    def description(self):
        return self.geometry
