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

import mujoco
import numpy as np

from testbed.errors import InputError
from testbed.math.validation import check_principal_inertia
from testbed.scenario.shipped_files import compile_model, load_spec
from testbed.scenario.schema import join, param

XML_FILE = "gyrostat_pair.xml"
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
    # the initial state of both gyrostats (the scenario's `initial` block is not used)
    leader_omega_rad_s: list[float] = param([0.1, 0.2, 0.3], length=3, doc="w(0), leader body axes")
    leader_moment_nms: list[float] = param([0.5, 1.0, 0.3], length=3, doc="lambda, held constant")
    follower_omega_rad_s: list[float] = param([0.05, 0.25, 0.0], length=3, doc="p(0)")
    follower_moment_nms: list[float] = param([0.2, -0.3, 0.4], length=3, doc="q(0)")

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
    spec = load_spec(XML_FILE, dt, integrator)
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
    return compile_model(spec)


def body_acceleration(inertia, omega, moment, moment_rate) -> np.ndarray:
    """w' of a gyrostat with principal inertias A and gyrostatic moment q (seed 003, eq. 1, 2):
    A w' = -w x (A w + q) - q'."""
    return (-np.cross(omega, inertia * omega + moment) - moment_rate) / inertia
