"""Add the appendages of `model.appendages` to a bus through MjSpec.

Each panel is a body on one hinge: its frame has x along the span, y along the hinge axis, its
origin on the hinge line; its CoM lies `com_offset_m` along x, and the next panel of the wing is
its child at x = `length_m`. The hinge carries the torsional spring and damper (MuJoCo joint
`stiffness`, `damping`, spring reference 0) and, with `range_deg`, the stops (joint `range`).
A spring-mass slosh model is a body on one slide joint per axis, each with its spring and
damper, its mass a uniform cube of half size SPRING_MASS_SIZE_M; a pendulum turns on two hinges
through the pivot, normal to the rod and to each other (a pivot body on the first carries the bob
on the second), its mass a uniform sphere of radius `length / PENDULUM_BOB_RATIO` at the rod's end
(drawn as a box).
"""

from __future__ import annotations

import mujoco
import numpy as np

from testbed.appendages.params import AppendagesParams, WingParams

PANEL_RGBA = [0.15, 0.25, 0.6, 1.0]
SLOSH_RGBA = [0.3, 0.7, 0.9, 1.0]
PENDULUM_BOB_RATIO = 10.0  # rod length / bob radius
SPRING_MASS_SIZE_M = 0.05  # half size of the cube a spring-mass is (drawn, and its inertia)


def panel_name(wing: int, panel: int) -> str:
    """Body and hinge name of panel `panel` (0-based) of wing `wing` (0-based)."""
    return f"wing{wing + 1}_panel{panel + 1}"


def slosh_name(index: int) -> str:
    """Body name of slosh model `index` (0-based); its joints add _a, _b, _c."""
    return f"slosh{index + 1}"


SLOSH_JOINT_SUFFIXES = ("_a", "_b", "_c")
BOB_SUFFIX = "_bob"  # a pendulum's bob, the child of its pivot body
PIVOT_SHARE = 1e-6  # a pendulum pivot's mass and inertia, of the bob's (its swing inertia: 4e-9 of the bob's)


def frame_quat(rotation: np.ndarray) -> list[float]:
    """MuJoCo quaternion (w, x, y, z) of a rotation matrix whose columns are the body axes."""
    quat = np.empty(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation, dtype=float).ravel())
    return quat.tolist()


def add_appendages(spec: mujoco.MjSpec, bus, params: AppendagesParams) -> None:
    """Add every wing and slosh model of `params` to `bus` (an MjSpec body), after everything
    the spec holds: their joints come last in the compiled model, wings first, in order."""
    for w, wing in enumerate(params.wings):
        add_wing(bus, w, wing)
    for k, slosh in enumerate(params.slosh):
        body = bus.add_body(name=slosh_name(k), pos=slosh.position_m, explicitinertial=True)
        hinge, slide = mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE
        if slosh.model == "spring_mass":
            body.mass = slosh.mass_kg
            body.ipos = [0.0, 0.0, 0.0]  # MjSpec leaves it unset
            body.inertia = [2.0 / 3.0 * slosh.mass_kg * SPRING_MASS_SIZE_M ** 2] * 3  # a uniform cube
            for axis, suffix in zip(slosh.slide_axes, SLOSH_JOINT_SUFFIXES):
                body.add_joint(name=slosh_name(k) + suffix, type=slide, axis=axis,
                               stiffness=slosh.stiffness(), damping=slosh.slide_damping())
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[SPRING_MASS_SIZE_M] * 3, contype=0,
                          conaffinity=0, mass=0, rgba=SLOSH_RGBA)
        else:
            # the pivot body turns on hinge _a and carries the bob on hinge _b: one hinge per body,
            # as the 3D view turns them; MuJoCo needs a mass for the moving pivot, PIVOT_SHARE of the bob's
            rod = np.asarray(slosh.rod_axis, float) * slosh.length_m
            radius = slosh.length_m / PENDULUM_BOB_RATIO
            bob_inertia = 0.4 * slosh.mass_kg * radius ** 2
            first, second = slosh.hinge_axes()
            body.mass = PIVOT_SHARE * slosh.mass_kg
            body.ipos = [0.0, 0.0, 0.0]
            body.inertia = [PIVOT_SHARE * bob_inertia] * 3
            body.add_joint(name=slosh_name(k) + SLOSH_JOINT_SUFFIXES[0], type=hinge, axis=first.tolist(),
                           damping=slosh.damping_nms_rad)
            bob = body.add_body(name=slosh_name(k) + BOB_SUFFIX, explicitinertial=True)
            bob.mass = slosh.mass_kg
            bob.ipos = rod.tolist()
            bob.inertia = [bob_inertia] * 3
            bob.add_joint(name=slosh_name(k) + SLOSH_JOINT_SUFFIXES[1], type=hinge, axis=second.tolist(),
                          damping=slosh.damping_nms_rad)
            bob.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[radius] * 3, pos=rod.tolist(), contype=0,
                         conaffinity=0, mass=0, rgba=SLOSH_RGBA)


def add_wing(bus, w: int, wing: WingParams) -> None:
    """The chain of panels of wing `w`, root first, each the child of the one before."""
    parent, pos, quat = bus, wing.hinge_position_m, frame_quat(wing.frame())
    for p, panel in enumerate(wing.panels):
        body = parent.add_body(name=panel_name(w, p), pos=pos, quat=quat, explicitinertial=True)
        body.mass = panel.mass_kg
        body.ipos = [panel.offset(), 0.0, 0.0]
        body.inertia = panel.inertia().tolist()
        joint = body.add_joint(name=panel_name(w, p), type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0.0, 1.0, 0.0],
                               stiffness=panel.stiffness_nm_rad, damping=panel.damping_nms_rad)
        if panel.range_deg is not None:
            joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
            joint.range = np.radians(panel.range_deg).tolist()
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, pos=[panel.length_m / 2.0, 0.0, 0.0],
                      size=[panel.length_m / 2.0, panel.width_m / 2.0, panel.thickness_m / 2.0],
                      contype=0, conaffinity=0, mass=0, rgba=PANEL_RGBA)
        parent, pos, quat = body, [panel.length_m, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]


def initial_positions(params: AppendagesParams) -> list[float]:
    """qpos of every appendage joint at the start, in the order add_appendages adds them
    (hinge angles [rad], slide offsets [m])."""
    values = [np.radians(panel.initial_angle_deg) for wing in params.wings for panel in wing.panels]
    for slosh in params.slosh:
        values += slosh.offsets() if slosh.model == "spring_mass" else np.radians(slosh.initial_angles_deg).tolist()
    return [float(v) for v in values]
