"""The variable-structure gyrostat (seed 002) as a plant: body torques on the carrier, the rod
and rotor on their prescribed angles, and the Euler-angle deviations from the program r(t).

Scenario parameters (`model: {system: gyrostat_variable, ...}`) are the domain's shapes and
servo settings plus the experiment of section 4: the program r(t) = r0 + r1 t (the paper's
phi* = t, psi* = pi/6, theta* = pi/4) and the initial deviations x(0), x'(0). The carrier
starts at q = r(0) + x(0), q' = r'(0) + x'(0); the scenario's `initial` block is not used.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.domains.gyrostat_variable import VariableGyrostat, VariableGyrostatParams, build
from testbed.errors import InputError
from testbed.euler_angles import body_rates, euler_from_quat, quat_from_euler
from testbed.plant import Plant
from testbed.schema import join, param

ANGLES = ("phi", "psi", "theta")


@dataclass(kw_only=True)
class VariableGyrostatScenarioParams(VariableGyrostatParams):
    program_angles_deg: list[float] = param([0.0, 30.0, 45.0], length=3,
                                            doc="r(0) = (phi*, psi*, theta*) at t = 0 (z-x-z Euler angles)")
    program_rates_rad_s: list[float] = param([1.0, 0.0, 0.0], length=3, doc="r' (constant): phi* = t")
    initial_deviation_rad: list[float] = param([0.004, 0.005, 0.005], length=3, doc="x(0) = q(0) - r(0)")
    initial_deviation_rate_rad_s: list[float] = param([0.002, 0.003, 0.003], length=3, doc="x'(0)")

    def validate(self, path: str) -> None:
        theta = np.radians(self.program_angles_deg[2]) + self.initial_deviation_rad[2]
        if abs(np.sin(theta)) < 1e-3:
            raise InputError(join(path, "program_angles_deg"), "theta must start away from 0 and 180 deg "
                             "(the z-x-z Euler angles are singular at sin theta = 0)")


def program(params: VariableGyrostatScenarioParams, t):
    """r(t), r'(t), r''(t) of the linear program r0 + r1 t (arrays broadcast over t)."""
    t = np.asarray(t, float)
    r0, r1 = np.radians(params.program_angles_deg), np.asarray(params.program_rates_rad_s, float)
    return r0 + np.multiply.outer(t, r1), np.broadcast_to(r1, t.shape + (3,)), np.zeros(t.shape + (3,))


def wrap(angle):
    return np.arctan2(np.sin(angle), np.cos(angle))


class VariableGyrostatPlant(Plant):
    """Truth adds the Euler angles (phi, psi, theta), the rod and rotor angles; after the run
    the deviations x = q - r(t) and x' = q' - r' per angle (the paper's Figs. 2-7)."""

    def __init__(self, model, params: VariableGyrostatScenarioParams):
        super().__init__(VariableGyrostat(model, params))
        self.domain.data = self.data  # the domain's servo references act on the plant's state
        self.params = params

    def initialise(self, initial) -> None:
        if np.any(initial.omega != 0) or not np.allclose(initial.quat, [1, 0, 0, 0]):
            raise InputError("initial", "gyrostat_variable starts on its program: give "
                             "model.initial_deviation_rad and model.initial_deviation_rate_rad_s instead")
        r, rd, _ = program(self.params, 0.0)
        q0 = r + np.asarray(self.params.initial_deviation_rad)
        qd0 = rd + np.asarray(self.params.initial_deviation_rate_rad_s)
        self.domain.reset(body_rates(q0, qd0), quat_from_euler(q0))

    def step(self, nstep: int) -> None:
        """Physics steps one at a time, each with the hinge servo references at its midpoint."""
        dt = self.model.opt.timestep
        for _ in range(nstep):
            self.domain.set_servo_references(self.time + dt / 2)
            super().step(1)

    def hinge_angles(self) -> np.ndarray:
        return self.domain.hinge_angles()

    def hinge_rates(self) -> np.ndarray:
        return self.domain.hinge_rates()

    def truth(self) -> dict[str, np.ndarray]:
        signals = super().truth()
        alpha, sigma = self.domain.hinge_angles()
        signals.update(euler_angles=euler_from_quat(signals["quat"]),
                       rod_angle=np.array([alpha]), rotor_angle=np.array([sigma]))
        return signals

    def derived_signals(self, recorder) -> dict[str, np.ndarray]:
        """x = q - r(t) (wrapped) and x' = E(q)^-1 w - r' per Euler angle."""
        t = recorder.time
        q, w = recorder["truth/euler_angles"], recorder["truth/omega"]
        r, rd, _ = program(self.params, t)
        phi, theta = q[:, 0], q[:, 2]
        p, qq, rr = w.T
        dpsi = (p * np.sin(phi) + qq * np.cos(phi)) / np.sin(theta)
        qd = np.column_stack([rr - dpsi * np.cos(theta), dpsi, p * np.cos(phi) - qq * np.sin(phi)])
        x, xd = wrap(q - r), qd - rd
        out = {"truth/deviation": x, "truth/deviation_rate": xd}
        for i, name in enumerate(ANGLES):
            out[f"truth/deviation_{name}"] = x[:, i]
            out[f"truth/deviation_rate_{name}"] = xd[:, i]
        return out

    def scene(self) -> dict:
        scene = super().scene()
        scene["bus_half_size"] = [self.params.carrier_radius_m, self.params.carrier_radius_m,
                                  self.params.carrier_height_m / 2]
        return scene


def make_plant(params: VariableGyrostatScenarioParams, sim) -> VariableGyrostatPlant:
    return VariableGyrostatPlant(build(params, sim.dt_s, sim.integrator), params)
