"""The planar rig as the runner sees it (model.py): a hinge, not a free body.

Overrides what differs from the free-flying `Plant`: the state is (angle, rate) of the
hinge about the world z axis; `omega` and `quat` describe that rotation as a body rate
(0, 0, rate) and a quaternion about z, so rate sensors and the 3D view work unchanged.
The `body_torque` command is applied through the hinge motor: its z component drives the
hinge, x and y are taken by the bearing (a hinge-mounted rig cannot turn about them).
The disturbance m(t) is switched on at the times the scenario gives, between physics steps.
"""

from __future__ import annotations

import mujoco
import numpy as np

from testbed.systems.planar.model import PlanarParams, PlanarRig, build
from testbed.errors import InputError
from testbed.plant import Plant
from testbed.scenario.schema import whole_multiple


class PlanarPlant(Plant):
    actuators = {"body_torque": (3,)}

    def __init__(self, params: PlanarParams, sim):
        super().__init__(PlanarRig(build(params, sim.dt_s, sim.integrator)))
        self.rig = self.bus
        self.params = params
        self.dt = sim.dt_s
        self.J = self.rig.inertia
        # Disturbance switch-ons on the physics grid, so each lands exactly between two steps.
        self._events = []
        for t, kind in params.events():
            key = "model.disturbance_start_s" if kind == "constant" else "model.ramp_start_s"
            n = 0 if t == 0 else whole_multiple(t, self.dt, key, "sim.dt_s")
            self._events.append((n, kind))
        self._step_index = 0

    # --- state --------------------------------------------------------------------------
    def angle(self) -> float:
        return self.rig.angle(self.data)

    def rate(self) -> float:
        return self.rig.rate(self.data)

    def omega(self) -> np.ndarray:
        return np.array([0.0, 0.0, self.rate()])

    def quat(self) -> np.ndarray:
        half = 0.5 * self.angle()
        return np.array([np.cos(half), 0.0, 0.0, np.sin(half)])

    def angular_momentum_world(self) -> np.ndarray:
        """J rate about z: the rig's momentum about the hinge (not conserved: the hinge is fixed)."""
        return np.array([0.0, 0.0, self.J * self.rate()])

    def locked_inertia(self) -> np.ndarray:
        return np.diag(self.model.body_inertia[self.rig.body_id]).astype(float)

    def momentum_scale(self) -> float:
        return max(abs(self.J * self.rate()), 1e-300)

    # --- stepping -----------------------------------------------------------------------
    def external_wrench(self) -> bool:
        """The disturbance motor's torque is the rig's surroundings acting on it (the accuracy guard reads it)."""
        return super().external_wrench() or bool(self.params.disturbance_rad_s2 or self.params.disturbance_rate_rad_s3)

    def initialise(self, initial) -> None:
        if (initial.omega_deg_s is not None or initial.omega_rad_s is not None
                or list(initial.quat) != [1.0, 0.0, 0.0, 0.0]):
            raise InputError("initial", "the planar rig takes its initial state from "
                                        "model.initial_angle_rad and model.initial_rate_rad_s")
        mujoco.mj_resetData(self.model, self.data)
        self.rig.set_state(self.data, self.params.initial_angle_rad, self.params.initial_rate_rad_s)
        self._step_index = 0
        self._fire_events()
        mujoco.mj_forward(self.model, self.data)

    def step(self, nstep: int) -> None:
        """Advance `nstep` physics steps, stopping at each disturbance switch-on inside them."""
        end = self._step_index + nstep
        for n, _ in self._events:
            if self._step_index < n < end:
                super().step(n - self._step_index)
                self._step_index = n
                self._fire_events()
        super().step(end - self._step_index)
        self._step_index = end
        self._fire_events()

    def _fire_events(self) -> None:
        p = self.params
        for n, kind in self._events:
            if n != self._step_index:
                continue
            if kind == "constant":
                self.rig.add_disturbance_torque(self.data, self.J * p.disturbance_rad_s2)
            else:
                self.rig.set_disturbance_torque_rate(self.data, self.J * p.disturbance_rate_rad_s3)

    # --- signals and commands -----------------------------------------------------------
    def truth(self) -> dict[str, np.ndarray]:
        signals = {"angle": np.array([self.angle()]), "rate": np.array([self.rate()]),
                   "quat": self.quat(),
                   "control_torque": np.array([self.rig.control_torque(self.data)]),
                   "disturbance_torque": np.array([self.rig.disturbance_torque(self.data)])}
        if self.record_energy:
            signals["kinetic_energy"] = np.array([self.kinetic_energy()])
        return signals

    def apply(self, command: dict[str, np.ndarray]) -> None:
        torque = command.get("body_torque")
        if torque is not None:
            self.rig.set_control_torque(self.data, float(np.asarray(torque)[2]))

    def description(self) -> dict:
        """Design data for controllers: the inertia J about the hinge [kg m^2]."""
        return {"hinge_inertia_kg_m2": self.J}

    def scene(self) -> dict:
        box = self.model.geom("rig_box")
        return {"bus_half_size": list(map(float, box.size)), "momentum_scale": 1.0}
