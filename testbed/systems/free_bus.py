"""A free-flying bus in a compiled model: the free joint named `bus`, its three ideal torque
motors, and the read-outs every free-flying system shares (body rate, attitude, locked
inertia about the system CoM, total angular momentum)."""

import mujoco
import numpy as np

from testbed.errors import InputError
from testbed.math.validation import MASS_RANGE_KG, check_in_range, check_principal_inertia, positive_number

BUS_BODY = "bus"
BUS_JOINT = "bus"
TORQUE_ACTUATORS = ("torque_x", "torque_y", "torque_z")
# the farthest a bus's CoM may sit from its origin, per axis [m]: past a spacecraft's size, and
# where m |c|^2 would swamp the inertia about the CoM that the read-outs subtract it from
MAX_COM_M = 100.0


def set_bus_mass(spec, inertia, mass) -> None:
    """Write the bus's principal inertia [kg m^2] and mass [kg] into `spec` (explicit inertial)."""
    check_principal_inertia(inertia, "model.inertia_kg_m2")
    bus = spec.body(BUS_BODY)
    bus.mass = check_in_range("model.mass_kg", positive_number("model.mass_kg", mass), MASS_RANGE_KG, "kg")
    bus.inertia = list(map(float, inertia))
    bus.explicitinertial = True


def full_inertia(tensor) -> list[float]:
    """MuJoCo's `fullinertia` order of a symmetric tensor [kg m^2]: (Ixx, Iyy, Izz, Ixy, Ixz, Iyz)."""
    m = np.asarray(tensor, dtype=float)
    return [m[0, 0], m[1, 1], m[2, 2], m[0, 1], m[0, 2], m[1, 2]]


def set_bus_inertia_tensor(spec, tensor, mass, com=(0.0, 0.0, 0.0)) -> None:
    """Write the bus's full inertia tensor [kg m^2] (3, 3), about its CoM in bus axes, its mass
    [kg] and its CoM `com` [m] (bus axes, from the bus origin) into `spec` (MuJoCo's fullinertia:
    it finds the principal axes when it compiles)."""
    bus = spec.body(BUS_BODY)
    bus.mass = check_in_range("model.mass_kg", positive_number("model.mass_kg", mass), MASS_RANGE_KG, "kg")
    bus.fullinertia = full_inertia(tensor)
    bus.ipos = [float(x) for x in com]
    bus.explicitinertial = True


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
        # the body rate and attitude within qvel and qpos, as slices: read every trace sample
        self.omega_dofs = slice(self.qvel_adr + 3, self.qvel_adr + 6)
        self.quat_coords = slice(self.qpos_adr + 3, self.qpos_adr + 7)
        self.torque_actuator_ids = np.array([model.actuator(n).id for n in TORQUE_ACTUATORS])

    def applied(self) -> dict:
        """The bus's own mass properties as compiled (what `set_bus_mass` or `set_bus_inertia_tensor`
        wrote), by scenario path."""
        return {"model.inertia_kg_m2": self.model.body_inertia[self.bus_body_id].tolist(),
                "model.mass_kg": float(self.model.body_mass[self.bus_body_id]),
                "model.com_m": self.model.body_ipos[self.bus_body_id].tolist()}

    def body_omega(self, data):
        """Body-frame angular velocity [rad/s]: a free joint's rotational qvel is body-frame."""
        return data.qvel[self.omega_dofs].copy()

    def state_views(self, data):
        """(body rate, attitude): views of `data`'s qvel and qpos that `body_omega` and `body_quat` copy."""
        return data.qvel[self.omega_dofs], data.qpos[self.quat_coords]

    def body_quat(self, data):
        """Attitude quaternion (w, x, y, z), body -> world."""
        return data.qpos[self.quat_coords].copy()

    def set_body_torque(self, data, torque_body):
        """Command the ideal torque [N m] about the bus axes (body frame)."""
        data.ctrl[self.torque_actuator_ids] = np.asarray(torque_body, dtype=float)

    def set_free_joint_state(self, data, omega0_body, quat0):
        """Place the bus origin at the world origin with attitude quat0 (normalised) and body-frame
        angular velocity omega0_body, the system CoM at rest: the free joint's linear velocity (the
        bus origin's, world axes) is -w x c, c the CoM from the bus origin (world axes), so a bus
        whose CoM is off its origin turns about its CoM instead of carrying it round the origin.
        Reads data's other joints (the CoM is the whole system's at their positions)."""
        quat = np.asarray(quat0, dtype=float)
        omega = np.asarray(omega0_body, dtype=float)
        if quat.shape != (4,) or not np.all(np.isfinite(quat)) or np.linalg.norm(quat) < 1e-9:
            raise InputError("quat0", f"expected a nonzero quaternion (w, x, y, z), got {quat0}")
        if omega.shape != (3,) or not np.all(np.isfinite(omega)):
            raise InputError("omega0_body", f"expected 3 finite numbers, got {omega0_body}")
        data.qpos[self.qpos_adr:self.qpos_adr + 3] = 0.0
        data.qpos[self.qpos_adr + 3:self.qpos_adr + 7] = quat / np.linalg.norm(quat)
        data.qvel[self.qvel_adr + 3:self.qvel_adr + 6] = omega
        mujoco.mj_kinematics(self.model, data)
        mujoco.mj_comPos(self.model, data)
        rot = data.xmat[self.bus_body_id].reshape(3, 3)
        com = data.subtree_com[self.bus_body_id] - data.xpos[self.bus_body_id]
        data.qvel[self.qvel_adr:self.qvel_adr + 3] = -np.cross(rot @ omega, com)

    def refresh(self, data, mass_matrix: bool = True):
        """Recompute kinematics, CoMs, mass matrix (unless `mass_matrix` is False: a read-out
        of velocities alone needs none) and body velocities from the current qpos, qvel. After
        mj_step, data holds these for the start of the step while qpos and qvel are already the
        new state; the read-outs below call this so they describe the current state. Touches
        nothing mj_step reads, so trajectories are unchanged."""
        mujoco.mj_kinematics(self.model, data)
        mujoco.mj_comPos(self.model, data)
        if mass_matrix:
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
        """System CoM relative to the bus origin, in bus axes [m] (the bus's own CoM `com_m`, every
        part's mass at its place, and the panels and slosh masses as they move); reads the
        kinematics stored in data (see refresh)."""
        rot = data.xmat[self.bus_body_id].reshape(3, 3)
        return rot.T @ (data.subtree_com[self.bus_body_id] - data.xpos[self.bus_body_id])

    def total_angular_momenta_world(self, models, datas, out: np.ndarray) -> np.ndarray:
        """`total_angular_momentum_world` of many worlds of this layout, into the rows of `out`
        (N, 3) [N m s]: the same MuJoCo calls (`refresh` without the mass matrix, then
        mj_subtreeVel) in one loop, without a method call per world (a batch's trace sample)."""
        kinematics, com_pos, com_vel, subtree_vel = (mujoco.mj_kinematics, mujoco.mj_comPos, mujoco.mj_comVel,
                                                     mujoco.mj_subtreeVel)
        body = self.bus_body_id
        for row, (model, data) in enumerate(zip(models, datas)):
            kinematics(model, data)
            com_pos(model, data)
            com_vel(model, data)
            subtree_vel(model, data)
            out[row] = data.subtree_angmom[body]
        return out

    def total_angular_momentum_world(self, data):
        """Angular momentum of the whole spacecraft about its CoM, world frame [N m s]
        (mj_subtreeVel fills subtree_angmom from the refreshed kinematics and velocities; it
        reads no mass matrix, and this runs at every trace sample)."""
        self.refresh(data, mass_matrix=False)
        mujoco.mj_subtreeVel(self.model, data)
        return data.subtree_angmom[self.bus_body_id].copy()
