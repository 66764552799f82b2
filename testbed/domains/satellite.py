"""Rigid satellite bus with ideal body-frame torques (models/satellite.xml).

Also holds the bus-level helpers the CMG domain reuses: parameter checks, applying the bus
mass properties and the integrator with MjSpec, and reading the free joint.
"""

from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from testbed.errors import InputError
from testbed.physical_checks import check_principal_inertia, positive_number

MODELS_DIR = Path(__file__).resolve().parents[2] / "models"
SATELLITE_XML = MODELS_DIR / "satellite.xml"

INTEGRATORS = {
    "Euler": mujoco.mjtIntegrator.mjINT_EULER,
    "RK4": mujoco.mjtIntegrator.mjINT_RK4,
    "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
}

BUS_BODY = "bus"
BUS_JOINT = "bus"
TORQUE_ACTUATORS = ("torque_x", "torque_y", "torque_z")


@dataclass(frozen=True)
class SatelliteParams:
    """Parameters of the rigid satellite.

    bus_inertia: principal moments of inertia of the bus about its CoM, along the bus axes
        [kg m^2]. (In the CMG domain this is the bus alone; the CMGs add to it.)
    bus_mass: [kg]. timestep: physics step [s]. integrator: one of INTEGRATORS.
    """

    bus_inertia: tuple = (800.0, 1000.0, 1200.0)
    bus_mass: float = 1000.0
    timestep: float = 1e-3
    integrator: str = "RK4"


def positive_vector(field, value, size):
    """`value` as a float array of `size` strictly positive finite entries, else InputError."""
    arr = np.asarray(value, dtype=float)
    if arr.shape != (size,):
        raise InputError(field, f"expected {size} numbers, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise InputError(field, f"all entries must be positive and finite, got {arr.tolist()}")
    return arr


def positive_scalar(field, value):
    """`value` as a strictly positive finite float, else InputError."""
    return positive_number(field, value)


def principal_inertia(field, value):
    """Checked principal inertia (3,): positive and obeying the triangle inequality."""
    inertia = positive_vector(field, value, 3)
    check_principal_inertia(inertia, field)
    return inertia


def apply_bus_params(spec, bus_inertia, bus_mass, timestep, integrator):
    """Write the bus mass properties, the timestep and the integrator into `spec`."""
    if integrator not in INTEGRATORS:
        raise InputError("integrator", f"{integrator!r} is not one of {sorted(INTEGRATORS)}")
    bus = spec.body(BUS_BODY)
    bus.mass = positive_scalar("bus_mass", bus_mass)
    bus.inertia = principal_inertia("bus_inertia", bus_inertia)
    bus.explicitinertial = True
    spec.option.timestep = positive_scalar("timestep", timestep)
    spec.option.integrator = INTEGRATORS[integrator]


def build(params: SatelliteParams) -> mujoco.MjModel:
    """Compile models/satellite.xml with every field of `params` applied through MjSpec."""
    spec = mujoco.MjSpec.from_file(str(SATELLITE_XML))
    apply_bus_params(spec, params.bus_inertia, params.bus_mass, params.timestep,
                     params.integrator)
    return spec.compile()


class FreeBus:
    """Addresses of the bus free joint and the three ideal torque motors in a compiled model."""

    def __init__(self, model):
        self.model = model
        joint = model.joint(BUS_JOINT)
        if joint.type[0] != mujoco.mjtJoint.mjJNT_FREE:
            raise ValueError(f"joint {BUS_JOINT!r} is not a free joint")
        self.bus_body_id = model.body(BUS_BODY).id
        self.qpos_adr = int(joint.qposadr[0])
        self.qvel_adr = int(joint.dofadr[0])
        self.torque_actuator_ids = np.array([model.actuator(n).id for n in TORQUE_ACTUATORS])

    def body_omega(self, data):
        """Body-frame angular velocity [rad/s]: a free joint's rotational qvel is body-frame."""
        return data.qvel[self.qvel_adr + 3:self.qvel_adr + 6].copy()

    def body_quat(self, data):
        """Attitude quaternion (w, x, y, z), body -> world."""
        return data.qpos[self.qpos_adr + 3:self.qpos_adr + 7].copy()

    def set_body_torque(self, data, torque_body):
        """Command the ideal torque [N m] about the bus axes (body frame)."""
        data.ctrl[self.torque_actuator_ids] = np.asarray(torque_body, dtype=float)

    def set_free_joint_state(self, data, omega0_body, quat0):
        """Place the bus at the origin at rest in translation, attitude quat0 (normalised),
        body-frame angular velocity omega0_body."""
        quat = np.asarray(quat0, dtype=float)
        omega = np.asarray(omega0_body, dtype=float)
        if quat.shape != (4,) or not np.all(np.isfinite(quat)) or np.linalg.norm(quat) < 1e-9:
            raise InputError("quat0", f"expected a nonzero quaternion (w, x, y, z), got {quat0}")
        if omega.shape != (3,) or not np.all(np.isfinite(omega)):
            raise InputError("omega0_body", f"expected 3 finite numbers, got {omega0_body}")
        data.qpos[self.qpos_adr:self.qpos_adr + 3] = 0.0
        data.qpos[self.qpos_adr + 3:self.qpos_adr + 7] = quat / np.linalg.norm(quat)
        data.qvel[self.qvel_adr:self.qvel_adr + 3] = 0.0
        data.qvel[self.qvel_adr + 3:self.qvel_adr + 6] = omega

    def refresh(self, data):
        """Recompute kinematics, CoMs, mass matrix and body velocities from the current
        qpos, qvel. After mj_step, data holds these for the start of the step while qpos and
        qvel are already the new state; the read-outs below call this so they describe the
        current state. Touches nothing mj_step reads, so trajectories are unchanged."""
        mujoco.mj_kinematics(self.model, data)
        mujoco.mj_comPos(self.model, data)
        mujoco.mj_makeM(self.model, data)
        mujoco.mj_comVel(self.model, data)

    def system_inertia(self, data):
        """Locked inertia of everything attached to the bus, about the system CoM, bus axes
        [kg m^2].

        The rotational block of the joint-space mass matrix (mj_fullM) is the locked inertia
        about the free joint's origin in body axes; the parallel-axis theorem moves it to
        the CoM: I_cm = I_o - m (|c|^2 1 - c c^T), c = CoM in body axes.
        """
        self.refresh(data)
        mass_matrix = np.zeros((self.model.nv, self.model.nv))
        mujoco.mj_fullM(self.model, data, mass_matrix)
        a = self.qvel_adr + 3
        inertia_origin = mass_matrix[a:a + 3, a:a + 3]
        com_body = self.com_offset_body(data)
        mass = self.model.body_subtreemass[self.bus_body_id]
        return inertia_origin - mass * (com_body @ com_body * np.eye(3)
                                        - np.outer(com_body, com_body))

    def com_offset_body(self, data):
        """System CoM relative to the bus origin, in bus axes [m] (zero by design); reads
        the kinematics stored in data (see refresh)."""
        rot = data.xmat[self.bus_body_id].reshape(3, 3)
        return rot.T @ (data.subtree_com[self.bus_body_id] - data.xpos[self.bus_body_id])

    def total_angular_momentum_world(self, data):
        """Angular momentum of the whole spacecraft about its CoM, world frame [N m s]
        (mj_subtreeVel fills subtree_angmom from the refreshed kinematics and velocities)."""
        self.refresh(data)
        mujoco.mj_subtreeVel(self.model, data)
        return data.subtree_angmom[self.bus_body_id].copy()


class Satellite(FreeBus):
    """The rigid satellite: the bus free joint and its three torque motors."""

    def initialise(self, data, omega0_body, quat0):
        """Reset `data` to attitude quat0 and body rate omega0_body, zero torque; mj_forward."""
        mujoco.mj_resetData(self.model, data)
        self.set_free_joint_state(data, omega0_body, quat0)
        mujoco.mj_forward(self.model, data)
