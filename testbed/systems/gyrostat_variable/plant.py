"""The variable-structure gyrostat (seed 002) as a plant: body torques on the carrier, the rod
and rotor servoed onto their prescribed angles, and the Euler-angle deviations from the
program r(t).

The carrier is the model's body "bus" (free joint, torque motors at O), read like any
spacecraft bus. It starts at q = r(0) + x(0), q' = r'(0) + x'(0) (model.py); the
scenario's `initial` block is not used.
"""

from __future__ import annotations

import mujoco
import numpy as np

from testbed.errors import InputError
from testbed.systems.free_bus import BUS_BODY, FreeBus
from testbed.math.euler_angles import angle_rates, body_rates, euler_from_quat, quat_from_euler
from testbed.plant import Plant
from testbed.systems.gyrostat_variable.model import (
    ACTUATORS, VariableGyrostatParams, deviations, inertia_about_point, prescribed, program)

ANGLES = ("phi", "psi", "theta")
HINGES = ("rod", "rotor")


class VariableGyrostatPlant(Plant):
    """Truth adds the Euler angles (phi, psi, theta), the rod and rotor angles; after the run
    the deviations x = q - r(t) and x' = q' - r' per angle (the paper's Figs. 2-7)."""

    def __init__(self, model: mujoco.MjModel, params: VariableGyrostatParams):
        super().__init__(FreeBus(model))
        self.params = params
        self._hinge_qpos = {n: int(model.joint(f"{n}_hinge").qposadr[0]) for n in HINGES}
        self._hinge_dof = {n: int(model.joint(f"{n}_hinge").dofadr[0]) for n in HINGES}
        self._act = {n: int(model.actuator(n).id) for n in ACTUATORS}

    def initialise(self, initial) -> None:
        if np.any(initial.omega != 0) or not np.allclose(initial.quat, [1, 0, 0, 0]):
            raise InputError("initial", "gyrostat_variable starts on its program: give "
                             "model.initial_deviation_rad and model.initial_deviation_rate_rad_s instead")
        r, rd, _ = program(self.params, 0.0)
        q0 = r + np.asarray(self.params.initial_deviation_rad)
        qd0 = rd + np.asarray(self.params.initial_deviation_rate_rad_s)
        self.reset(body_rates(q0, qd0), quat_from_euler(q0))

    def reset(self, omega_body, quat=(1.0, 0.0, 0.0, 0.0)) -> None:
        """Carrier at rest position O = 0 with attitude `quat` and body rate `omega_body`; the
        rod and rotor start on their prescribed trajectories (angle 0, prescribed rate)."""
        mujoco.mj_resetData(self.model, self.data)
        a, b = self.bus.qpos_adr, self.bus.qvel_adr
        self.data.qpos[a + 3:a + 7] = np.asarray(quat, float) / np.linalg.norm(quat)
        self.data.qvel[b + 3:b + 6] = omega_body
        ref = prescribed(0.0, self.params)
        for n in HINGES:
            self.data.qvel[self._hinge_dof[n]] = ref[f"{n}_rate"]
            self.data.act[self.model.actuator_actadr[self._act[f"{n}_angle"]]] = ref[f"{n}_angle"]
        self.set_servo_references(0.0)
        mujoco.mj_forward(self.model, self.data)

    def step(self, nstep: int) -> None:
        """Physics steps one at a time, each with the hinge servo references at its midpoint
        (the reference angles are the servos' activations, integrated inside the step)."""
        dt = self.model.opt.timestep
        for _ in range(nstep):
            self.set_servo_references(self.time + dt / 2)
            super().step(1)

    def set_servo_references(self, t: float) -> None:
        """Hinge servo controls at time t: both actuators of a hinge take the prescribed rate
        (the <intvelocity> one integrates it into the reference angle)."""
        ref = prescribed(t, self.params)
        for n in HINGES:
            self.data.ctrl[self._act[f"{n}_angle"]] = ref[f"{n}_rate"]
            self.data.ctrl[self._act[f"{n}_rate"]] = ref[f"{n}_rate"]

    def hinge_angles(self) -> np.ndarray:
        """(alpha, sigma): rod and rotor hinge angles [rad]."""
        return np.array([self.data.qpos[self._hinge_qpos[n]] for n in HINGES])

    def hinge_rates(self) -> np.ndarray:
        """(alpha', sigma') [rad/s]."""
        return np.array([self.data.qvel[self._hinge_dof[n]] for n in HINGES])

    def tracking_error(self) -> dict[str, float]:
        """Hinge angle minus prescribed angle [rad] at the current time."""
        ref = prescribed(self.time, self.params)
        return {n: float(self.data.qpos[self._hinge_qpos[n]] - ref[f"{n}_angle"]) for n in HINGES}

    def carrier_inertia(self) -> np.ndarray:
        """I1 about O in carrier axes: cylinder + rod at the current rod angle (paper's I1x,y,z)."""
        return inertia_about_point(self.model, self.data, (BUS_BODY, "rod"), BUS_BODY)

    def rotor_inertia(self) -> np.ndarray:
        """I2 about O in the rotor's axes x2 y2 z2 (paper's I2x,y,z)."""
        return inertia_about_point(self.model, self.data, ("rotor",), "rotor",
                                   point=self.data.xpos[self.bus.bus_body_id])

    def truth(self) -> dict[str, np.ndarray]:
        signals = super().truth()
        alpha, sigma = self.hinge_angles()
        signals.update(euler_angles=euler_from_quat(signals["quat"]),
                       rod_angle=np.array([alpha]), rotor_angle=np.array([sigma]))
        return signals

    def derived_signals(self, recorder) -> dict[str, np.ndarray]:
        """x = q - r(t) (wrapped) and x' = E(q)^-1 w - r' per Euler angle."""
        q = recorder["truth/euler_angles"]
        x, xd = deviations(self.params, recorder.time, q, angle_rates(q, recorder["truth/omega"]))
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
