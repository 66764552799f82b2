"""The appendages of a compiled model (testbed.appendages.build), known by their names: their
coordinates as views of MuJoCo's arrays, what the trace records of them, the hinges the 3D view
turns, and their mass at rest for a rigid reduced model."""

from __future__ import annotations

import re

import mujoco
import numpy as np

PANEL_JOINT = re.compile(r"wing\d+_panel\d+")
SLOSH_JOINT = re.compile(r"slosh\d+_[abc]")
APPENDAGE_BODY = re.compile(r"wing\d+_panel\d+|slosh\d+")
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
        self.slosh_hinge_names = [names[j] for j in slosh if model.jnt_type[j] == hinge]
        self.slosh_slide_names = [names[j] for j in slosh if model.jnt_type[j] != hinge]
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

    def hinge_signals(self) -> dict[str, tuple[str, int]]:
        """Hinge joint name -> (recorded signal, column) for the 3D view (recording.scene.moving_parts)."""
        return {name: (f"truth/{PANEL_SIGNAL}", i) for i, name in enumerate(self.panel_names)}


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
