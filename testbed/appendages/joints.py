"""The appendages of a compiled model (testbed.appendages.build), known by their names: their
coordinates as views of MuJoCo's arrays, what the trace records of them, the hinges the 3D view
turns, and their mass at rest for a rigid reduced model."""

from __future__ import annotations

import re

import mujoco
import numpy as np

PANEL_JOINT = re.compile(r"wing(\d+)_panel(\d+)")
SLOSH_JOINT = re.compile(r"slosh\d+_[abc]")
APPENDAGE_BODY = re.compile(r"wing\d+_panel\d+|slosh\d+(_bob)?")
PANEL_SIGNAL, SLOSH_ANGLE_SIGNAL, SLOSH_OFFSET_SIGNAL = "panel_angle", "slosh_angle", "slosh_offset"


def is_appendage(model: mujoco.MjModel, body: int) -> bool:
    """Whether body `body` of `model` is a panel or a slosh mass (build.py's names)."""
    return APPENDAGE_BODY.fullmatch(model.body(body).name) is not None


class AppendageJoints:
    """The panel hinges and slosh joints of a compiled model on `data`, in model order."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData):
        names = [model.joint(j).name for j in range(model.njnt)]
        self.panel_names = [n for n in names if PANEL_JOINT.fullmatch(n)]
        slosh = [j for j, n in enumerate(names) if SLOSH_JOINT.fullmatch(n)]
        hinge = mujoco.mjtJoint.mjJNT_HINGE
        self.slosh_hinge_names = [names[j] for j in slosh if int(model.jnt_type[j]) == hinge]
        self.slosh_slide_names = [names[j] for j in slosh if int(model.jnt_type[j]) != hinge]
        self.panel_qpos = self._addresses(model, self.panel_names)
        self.slosh_hinge_qpos = self._addresses(model, self.slosh_hinge_names)
        self.slosh_slide_qpos = self._addresses(model, self.slosh_slide_names)
        self.qpos = data.qpos

    @staticmethod
    def _addresses(model, names) -> np.ndarray:
        return np.array([model.joint(n).qposadr[0] for n in names], dtype=int)

    @classmethod
    def find(cls, model: mujoco.MjModel, data: mujoco.MjData) -> AppendageJoints | None:
        """The model's appendages, or None when it has none."""
        found = cls(model, data)
        return found if found.panel_names or found.slosh_hinge_names or found.slosh_slide_names else None

    def set_positions(self, values) -> None:
        """Write every appendage coordinate (build.initial_positions's order: panels, then each
        slosh model's joints) [rad or m]."""
        addresses = np.concatenate([self.panel_qpos, self._slosh_in_model_order()])
        self.qpos[addresses] = values

    def _slosh_in_model_order(self) -> np.ndarray:
        return np.sort(np.concatenate([self.slosh_hinge_qpos, self.slosh_slide_qpos]))

    def truth(self) -> dict[str, np.ndarray]:
        """`panel_angle` (hinge deflections [rad], wing by wing, root first), `slosh_angle`
        (the pendulums' two hinge angles each [rad]) and `slosh_offset` (the spring-masses'
        slide offsets [m]), those the model has."""
        signals = {}
        for key, addresses in ((PANEL_SIGNAL, self.panel_qpos), (SLOSH_ANGLE_SIGNAL, self.slosh_hinge_qpos),
                               (SLOSH_OFFSET_SIGNAL, self.slosh_slide_qpos)):
            if len(addresses):
                signals[key] = self.qpos[addresses]
        return signals

    def fastest_mode(self, model: mujoco.MjModel) -> float:
        """The fastest pole |s| [rad/s] of the joints' springs and dampers at rest (qpos0), every
        other joint and the bus free: the largest eigenvalue modulus of [[0, 1], [-M^-1 K, -M^-1 C]],
        K and C the joints' stiffness and damping on their dofs. What one explicit step must resolve
        (testbed.accuracy.step_size): a stiff spring's frequency, or a heavy damper's rate c / J."""
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        mass = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, mass)
        stiffness = np.zeros(model.nv)
        for joint in np.flatnonzero(model.jnt_stiffness):
            if int(model.jnt_type[joint]) in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
                stiffness[model.jnt_dofadr[joint]] = model.jnt_stiffness[joint]
        solved = np.linalg.solve(mass, np.hstack([np.diag(stiffness), np.diag(model.dof_damping)]))
        n = model.nv
        system = np.block([[np.zeros((n, n)), np.eye(n)], [-solved[:, :n], -solved[:, n:]]])
        return float(np.max(np.abs(np.linalg.eigvals(system))))

    def applied(self, model: mujoco.MjModel) -> dict:
        """Each panel's mass, hinge stiffness and damping as compiled, by scenario path
        (`model.appendages.wings.W.panels.P.stiffness_nm_rad`, 0-based; Plant.applied)."""
        values = {}
        for name in self.panel_names:
            wing, panel = (int(i) - 1 for i in PANEL_JOINT.fullmatch(name).groups())
            joint = model.joint(name)
            path = f"model.appendages.wings.{wing}.panels.{panel}"
            values |= {f"{path}.mass_kg": float(model.body(name).mass[0]),
                       f"{path}.stiffness_nm_rad": float(joint.stiffness[0]),
                       f"{path}.damping_nms_rad": float(model.dof_damping[joint.dofadr[0]])}
        return values

    def hinge_signals(self) -> dict[str, tuple[str, int]]:
        """Hinge joint name -> (recorded signal, column) for the 3D view (recording.scene.moving_parts):
        the panels and the pendulums' pivots and bobs (the spring-masses are drawn at rest)."""
        panels = {name: (f"truth/{PANEL_SIGNAL}", i) for i, name in enumerate(self.panel_names)}
        return panels | {name: (f"truth/{SLOSH_ANGLE_SIGNAL}", i) for i, name in enumerate(self.slosh_hinge_names)}


def free_spinner_axis(model: mujoco.MjModel, body: int) -> np.ndarray | None:
    """The hinge axis (the body's frame) of `body` when it spins
    freely on one hinge: no spring, damper, friction nor servo (a biased actuator) on it, as an
    unpowered reaction wheel; None otherwise (a gimbal or a servoed rotor is held)."""
    if model.body_jntnum[body] != 1:
        return None
    joint = model.body_jntadr[body]
    dof = model.jnt_dofadr[joint]
    if int(model.jnt_type[joint]) != mujoco.mjtJoint.mjJNT_HINGE or model.jnt_stiffness[joint] \
            or model.dof_damping[dof] or model.dof_frictionloss[dof]:
        return None
    on_joint = (model.actuator_trntype == int(mujoco.mjtTrn.mjTRN_JOINT)) & (model.actuator_trnid[:, 0] == joint)
    if np.any(model.actuator_biastype[on_joint] != int(mujoco.mjtBias.mjBIAS_NONE)):
        return None
    return model.jnt_axis[joint]


def rigid_mass(model: mujoco.MjModel, bus: int) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass [kg], CoM [m], inertia about the CoM [kg m^2]) of every body but the appendages
    at qpos0, in the frame of body `bus`: the rigid part the closed forms hang the appendages on
    (testbed.appendages.closed_form.RigidPart). Gimbals and servoed rotors count as locked; a
    body that spins freely on its hinge (free_spinner_axis: an unpowered wheel, its CoM on the
    axis) keeps its spin out of the bus's turning, so it adds J - (J a)(J a)^T / (a^T J a)
    about its CoM (a its axis), Jt (1 - a a^T) for an axisymmetric wheel."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    rot_bus, pos_bus = data.xmat[bus].reshape(3, 3), data.xpos[bus]
    bodies = [b for b in range(1, model.nbody) if not is_appendage(model, b)]
    masses = model.body_mass[bodies]
    coms = (data.xipos[bodies] - pos_bus) @ rot_bus
    com = masses @ coms / masses.sum()
    inertia = np.zeros((3, 3))
    for body, mass, position in zip(bodies, masses, coms):
        principal = rot_bus.T @ data.ximat[body].reshape(3, 3)
        own = principal @ np.diag(model.body_inertia[body]) @ principal.T
        axis = free_spinner_axis(model, body)
        if axis is not None:
            spin = rot_bus.T @ data.xmat[body].reshape(3, 3) @ axis
            turned = own @ spin
            own = own - np.outer(turned, turned) / (spin @ turned)
        r = position - com
        inertia += own + mass * (r @ r * np.eye(3) - np.outer(r, r))
    return float(masses.sum()), com, inertia


def locked_appendage_mass(model: mujoco.MjModel, bus: int) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """(mass [kg], CoM [m], inertia about the CoM [kg m^2]) of each appendage body at rest
    (qpos0), in the frame of body `bus`: what a rigid model of the spacecraft counts them as."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    rot_bus, pos_bus = data.xmat[bus].reshape(3, 3), data.xpos[bus]
    found = []
    for body in range(model.nbody):
        if not is_appendage(model, body):
            continue
        principal = rot_bus.T @ data.ximat[body].reshape(3, 3)
        found.append((float(model.body_mass[body]), rot_bus.T @ (data.xipos[body] - pos_bus),
                      principal @ np.diag(model.body_inertia[body]) @ principal.T))
    return found
