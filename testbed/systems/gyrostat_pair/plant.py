"""The leader/follower gyrostat pair (seed 003) as a plant.

The leader is the "bus" the runner knows: `omega`, `quat` and the reference check are the
leader's. Truth adds the follower's rates p and both gyrostatic moments (lambda, q). The one
actuator is the follower's rotor-momentum rate q' (`follower_moment_rate`), realised by its
rotor motors as tau = q' + J w' (model.py). The initial state of both gyrostats is part of
the system parameters; the scenario's `initial` block is not used.
"""

from __future__ import annotations

import mujoco
import numpy as np

from testbed.errors import InputError
from testbed.plant import Plant
from testbed.systems.gyrostat_pair.model import ROLES, GyrostatPairParams, body_acceleration


class PairAddresses:
    """The pair's free joints, rotor hinges and actuators in a compiled model, by name."""

    def __init__(self, model: mujoco.MjModel):
        self.model = model
        self.free_qpos = {r: int(model.joint(f"{r}_free").qposadr[0]) for r in ROLES}
        self.free_dof = {r: int(model.joint(f"{r}_free").dofadr[0]) for r in ROLES}
        self.rotor_dof = {r: [int(model.joint(f"{r}_rotor{i}").dofadr[0]) for i in (1, 2, 3)] for r in ROLES}
        self.body = {r: int(model.body(r).id) for r in ROLES}
        self.speed_act = [int(model.actuator(f"leader_rotor{i}_speed").id) for i in (1, 2, 3)]
        self.torque_act = [int(model.actuator(f"follower_rotor{i}_torque").id) for i in (1, 2, 3)]

    def state_views(self, data):
        """None: two free bodies, no one bus whose rate and attitude `Plant` could read through views."""
        return None

    def applied(self) -> dict:
        """No bus mass properties of the scenario's to read back (the pair's are its own)."""
        return {}


class GyrostatPairPlant(Plant):
    actuators = {"follower_moment_rate": (3,)}
    holds_internal_momentum = True

    def __init__(self, model: mujoco.MjModel, params: GyrostatPairParams):
        super().__init__(PairAddresses(model))
        self.params = params
        self.A = np.asarray(params.inertia_kg_m2, float)
        self.J = params.rotor_axial_inertia_kg_m2

    def initialise(self, initial) -> None:
        if np.any(initial.omega != 0) or not np.allclose(initial.quat, [1, 0, 0, 0]):
            raise InputError("initial", "gyrostat_pair takes its initial state from model.leader_omega_rad_s, "
                             "model.follower_omega_rad_s and the moments")
        p = self.params
        self.reset(p.leader_omega_rad_s, p.leader_moment_nms, p.follower_omega_rad_s, p.follower_moment_nms)

    def reset(self, leader_omega, leader_moment, follower_omega, follower_moment,
              leader_quat=(1.0, 0.0, 0.0, 0.0), follower_quat=(1.0, 0.0, 0.0, 0.0)) -> None:
        """Set both body rates (body frame), attitudes and gyrostatic moments lambda and q;
        the leader's speed servos are commanded to hold lambda."""
        mujoco.mj_resetData(self.model, self.data)
        a = self.bus
        for role, omega, moment, quat in (("leader", leader_omega, leader_moment, leader_quat),
                                          ("follower", follower_omega, follower_moment, follower_quat)):
            q, v = a.free_qpos[role], a.free_dof[role]
            self.data.qpos[q + 3:q + 7] = np.asarray(quat, float) / np.linalg.norm(quat)
            self.data.qvel[v + 3:v + 6] = omega
            self.data.qvel[a.rotor_dof[role]] = np.asarray(moment, float) / self.J
        self.data.ctrl[a.speed_act] = np.asarray(leader_moment, float) / self.J
        mujoco.mj_forward(self.model, self.data)

    # --- state --------------------------------------------------------------------------
    def role_omega(self, role: str) -> np.ndarray:
        """Body-frame angular velocity of `role` ("leader" or "follower")."""
        b = self.bus.free_dof[role] + 3
        return self.data.qvel[b:b + 3].copy()

    def moment(self, role: str) -> np.ndarray:
        """Gyrostatic moment J * (rotor hinge speeds): lambda for the leader, q for the follower."""
        return self.J * self.data.qvel[self.bus.rotor_dof[role]]

    def omega(self) -> np.ndarray:
        return self.role_omega("leader")

    def quat(self) -> np.ndarray:
        q = self.bus.free_qpos["leader"] + 3
        return self.data.qpos[q:q + 4].copy()

    def _refresh(self) -> None:
        """Kinematics and velocities of the current state (after mj_step they lag one step)."""
        for fn in (mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_comVel, mujoco.mj_subtreeVel):
            fn(self.model, self.data)

    def role_angular_momentum_world(self, role: str) -> np.ndarray:
        """Angular momentum of one gyrostat (platform + rotors) about its CoM, world frame."""
        self._refresh()
        return self.data.subtree_angmom[self.bus.body[role]].copy()

    def angular_momentum_world(self) -> np.ndarray:
        """Sum of both gyrostats' momenta about their own centres of mass (each is conserved)."""
        self._refresh()
        return sum(self.data.subtree_angmom[b].copy() for b in self.bus.body.values())

    def locked_inertia(self) -> np.ndarray:
        """The leader's A (rotors locked), from the rotational block of mj_fullM."""
        mujoco.mj_forward(self.model, self.data)
        full = np.zeros((self.model.nv, self.model.nv))
        mujoco.mj_fullM(self.model, self.data, full)
        a = self.bus.free_dof["leader"] + 3
        return full[a:a + 3, a:a + 3].copy()

    def kinetic_energy(self) -> float:
        """1/2 w.A w + 1/2 p.A p [J]: the energy of eq. (1) that is conserved while both
        gyrostatic moments are constant (the rotors' own spin energy is left out: the leader's
        speed servos do work on its rotors, so the total kinetic energy is not conserved)."""
        w, p = self.role_omega("leader"), self.role_omega("follower")
        return float(0.5 * (w @ (self.A * w) + p @ (self.A * p)))

    def internal_momentum_body(self) -> np.ndarray:
        return self.moment("leader")

    # --- signals and commands -----------------------------------------------------------
    def truth(self) -> dict[str, np.ndarray]:
        signals = super().truth()
        signals.update(follower_omega=self.role_omega("follower"),
                       leader_moment=self.moment("leader"),
                       follower_moment=self.moment("follower"))
        return signals

    def derived_signals(self, recorder) -> dict[str, np.ndarray]:
        """Synchronisation error p - w (follower minus leader rates)."""
        return {"truth/sync_error": recorder["truth/follower_omega"] - recorder["truth/omega"]}

    def follower_torques(self, q_dot) -> np.ndarray:
        """Motor torques tau = q' + J w' realising the rotor-momentum rate q' (model.py),
        with w' = A^-1 (-p x (A p + q) - q') from the follower's eq. (2)."""
        q_dot = np.asarray(q_dot, float)
        p, q = self.role_omega("follower"), self.moment("follower")
        return q_dot + self.J * body_acceleration(self.A, p, q, q_dot)

    def apply(self, command: dict[str, np.ndarray]) -> None:
        q_dot = command.get("follower_moment_rate")
        if q_dot is not None:
            self.data.ctrl[self.bus.torque_act] = self.follower_torques(q_dot)

    def scene(self) -> dict:
        """The 3D view shows the leader's box (the base class looks for a body named bus)."""
        box = self.model.geom("leader_box").id
        return {"bus_half_size": list(map(float, self.model.geom_size[box])),
                "momentum_scale": 1.0 / max(self.momentum_scale(), 1e-9)}
