"""Leader and follower gyrostats of seed 003 (models/gyrostat_pair.xml).

Each gyrostat is a free platform with three axisymmetric rotors (axial J, transverse Jt)
centred at its CoM, spinning about body axes x, y, z. In the paper's variables (eq. 1, 2):
A = the inertias with the rotors locked (platform + rotors), and the gyrostatic moment is the
rotors' momentum relative to the platform, lambda_i = J Omega_i (Omega_i = hinge speed), so

    A w' = -w x (A w + lambda) - lambda'.

Leader: velocity servos hold Omega_i = lambda_i / J (constant lambda). Follower: the control
is q' (its rotor-momentum rate). A rotor's axial equation is J (w_i' + Omega_i') = tau_i
(exact for an axisymmetric rotor), so q_i' = J Omega_i' = tau_i - J w_i', and the motor
torque that realises a commanded q' is tau = q' + J w', with w' from eq. (2) at the current
state. The torque is held over each step, so q' is realised to O(dt).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from testbed.errors import InputError
from testbed.physical_checks import check_principal_inertia
from testbed.schema import join, param

XML = Path(__file__).resolve().parents[2] / "models" / "gyrostat_pair.xml"
ROLES = ("leader", "follower")


@dataclass
class GyrostatPairParams:
    system: str = "gyrostat_pair"
    inertia_kg_m2: list[float] = param([20.0, 30.0, 40.0], length=3,
                                       doc="A1, A2, A3: principal inertias with the rotors locked")
    body_mass_kg: float = param(100.0, gt=0, doc="platform mass")
    rotor_mass_kg: float = param(1.0, gt=0)
    rotor_axial_inertia_kg_m2: float = param(0.05, gt=0, doc="J")
    rotor_transverse_inertia_kg_m2: float = param(0.03, gt=0, doc="Jt")
    leader_speed_servo_bandwidth_rad_s: float = param(200.0, gt=0, doc="kv = J * bandwidth")

    def validate(self, path: str) -> None:
        check_principal_inertia(self.inertia_kg_m2, join(path, "inertia_kg_m2"))
        js, jt = self.rotor_axial_inertia_kg_m2, self.rotor_transverse_inertia_kg_m2
        if js > 2 * jt + 1e-12:
            raise InputError(join(path, "rotor_axial_inertia_kg_m2"),
                             f"an axisymmetric rotor needs J <= 2 Jt, got {js:g} > {2 * jt:g}")
        platform = platform_inertia(self)
        if np.any(platform <= 0) or np.any(2 * platform > platform.sum() + 1e-12 * platform.sum()):
            raise InputError(join(path, "inertia_kg_m2"),
                             f"less the rotors (J + 2 Jt = {js + 2 * jt:g} per axis) the platform "
                             f"inertia {list(platform)} is not a physical body")


def platform_inertia(params: GyrostatPairParams) -> np.ndarray:
    """Platform inertia = A - rotors: each axis carries one rotor's J and two rotors' Jt."""
    rotors = params.rotor_axial_inertia_kg_m2 + 2 * params.rotor_transverse_inertia_kg_m2
    return np.asarray(params.inertia_kg_m2, float) - rotors


def build(params: GyrostatPairParams, dt: float = 1e-3, integrator: str = "RK4") -> mujoco.MjModel:
    """Compile models/gyrostat_pair.xml with inertias and servo gains applied through MjSpec."""
    bandwidth = params.leader_speed_servo_bandwidth_rad_s
    if bandwidth * dt > 0.5:
        raise InputError("model.leader_speed_servo_bandwidth_rad_s",
                         f"bandwidth x time step = {bandwidth * dt:g} must stay below 0.5 for RK4")
    spec = mujoco.MjSpec.from_file(str(XML))
    spec.option.timestep = dt
    spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator.upper()}")
    J, Jt = params.rotor_axial_inertia_kg_m2, params.rotor_transverse_inertia_kg_m2
    for role in ROLES:
        body = spec.body(role)
        body.mass = params.body_mass_kg
        body.inertia = platform_inertia(params)
        for i in range(3):
            rotor = spec.body(f"{role}_rotor{i + 1}")
            rotor.mass = params.rotor_mass_kg
            rotor.inertia = [J if k == i else Jt for k in range(3)]  # axial moment on axis i
    for i in range(3):
        spec.actuator(f"leader_rotor{i + 1}_speed").set_to_velocity(kv=J * bandwidth)
    return spec.compile()


class GyrostatPair:
    """Compiled pair plus data; knows the free joints, rotor hinges and actuators by name."""

    def __init__(self, model: mujoco.MjModel, params: GyrostatPairParams):
        self.model = model
        self.data = mujoco.MjData(model)
        self.params = params
        self.A = np.asarray(params.inertia_kg_m2, float)
        self.J = params.rotor_axial_inertia_kg_m2
        self._free_qpos = {r: int(model.joint(f"{r}_free").qposadr[0]) for r in ROLES}
        self._free_dof = {r: int(model.joint(f"{r}_free").dofadr[0]) for r in ROLES}
        self._rotor_dof = {r: [int(model.joint(f"{r}_rotor{i}").dofadr[0]) for i in (1, 2, 3)] for r in ROLES}
        self._body = {r: int(model.body(r).id) for r in ROLES}
        self._speed_act = [int(model.actuator(f"leader_rotor{i}_speed").id) for i in (1, 2, 3)]
        self._torque_act = [int(model.actuator(f"follower_rotor{i}_torque").id) for i in (1, 2, 3)]
        self._badqacc = mujoco.mjtWarning.mjWARN_BADQACC

    def reset(self, leader_omega, leader_moment, follower_omega, follower_moment,
              leader_quat=(1.0, 0.0, 0.0, 0.0), follower_quat=(1.0, 0.0, 0.0, 0.0)) -> None:
        """Set both body rates (body frame), attitudes and gyrostatic moments lambda and q;
        the leader's speed servos are commanded to hold lambda."""
        mujoco.mj_resetData(self.model, self.data)
        for role, omega, moment, quat in (("leader", leader_omega, leader_moment, leader_quat),
                                          ("follower", follower_omega, follower_moment, follower_quat)):
            a, b = self._free_qpos[role], self._free_dof[role]
            self.data.qpos[a + 3:a + 7] = np.asarray(quat, float) / np.linalg.norm(quat)
            self.data.qvel[b + 3:b + 6] = omega
            self.data.qvel[self._rotor_dof[role]] = np.asarray(moment, float) / self.J
        self.data.ctrl[self._speed_act] = np.asarray(leader_moment, float) / self.J
        mujoco.mj_forward(self.model, self.data)

    def omega(self, role: str) -> np.ndarray:
        """Body-frame angular velocity of `role` ("leader" or "follower")."""
        b = self._free_dof[role] + 3
        return self.data.qvel[b:b + 3].copy()

    def moment(self, role: str) -> np.ndarray:
        """Gyrostatic moment J * (rotor hinge speeds): lambda for the leader, q for the follower."""
        return self.J * self.data.qvel[self._rotor_dof[role]]

    def angular_momentum_world(self, role: str) -> np.ndarray:
        """Angular momentum of one gyrostat (platform + rotors) about its CoM, world frame."""
        mujoco.mj_subtreeVel(self.model, self.data)
        return self.data.subtree_angmom[self._body[role]].copy()

    def follower_torques(self, q_dot) -> np.ndarray:
        """Motor torques tau = q' + J w' realising the rotor-momentum rate q' (see module doc),
        with w' = A^-1 (-p x (A p + q) - q') from the follower's eq. (2)."""
        q_dot = np.asarray(q_dot, float)
        p, q = self.omega("follower"), self.moment("follower")
        p_dot = (-np.cross(p, self.A * p + q) - q_dot) / self.A
        return q_dot + self.J * p_dot

    def command_follower(self, q_dot) -> None:
        """Hold the motor torques for `q_dot` over the next steps."""
        self.data.ctrl[self._torque_act] = self.follower_torques(q_dot)

    def step(self, nstep: int = 1) -> None:
        """Advance `nstep` physics steps; stop with an error on a bad acceleration."""
        mujoco.mj_step(self.model, self.data, nstep=nstep)
        if self.data.warning[self._badqacc].number or not np.isfinite(self.data.qvel).all():
            raise RuntimeError(f"simulation diverged at t = {self.data.time:.6g} s")
