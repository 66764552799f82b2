"""What the 3D view draws of the parts that move on a free bus, read from the compiled model.

A plant's `scene()` may list `moving_parts` (testbed.recording.trace draws them): every body below the bus,
parents first, with its pose in its parent, the hinge that turns it (when a recorded signal holds
that hinge's angle) and its geoms as shapes. Nothing is placed by hand: positions, orientations,
sizes and colours are the compiled model's (`body_pos`, `body_quat`, `jnt_axis`, `jnt_pos`,
`geom_size`, `geom_pos`, `geom_quat`, `geom_rgba`). Boxes and cylinders are drawn; other geom
types are left out. Quaternions are MuJoCo's (w, x, y, z).
"""

from __future__ import annotations

import mujoco
import numpy as np

from testbed.math.quaternion import quat_mul, quat_rotate

SHAPES = {int(mujoco.mjtGeom.mjGEOM_BOX): "box", int(mujoco.mjtGeom.mjGEOM_CYLINDER): "cylinder"}


def body_shapes(model, body: int) -> list[dict]:
    """The drawable geoms of `body`: kind ("box": size = half sizes (3,); "cylinder": size =
    (radius, half length) about the local z axis), pos, quat in the body frame, rgba (0-255)."""
    shapes = []
    for g in range(model.ngeom):
        kind = SHAPES.get(int(model.geom_type[g]))
        if model.geom_bodyid[g] != body or kind is None:
            continue
        size = model.geom_size[g][:3] if kind == "box" else model.geom_size[g][:2]
        shapes.append({"kind": kind, "size": size.tolist(), "pos": model.geom_pos[g].tolist(),
                       "quat": model.geom_quat[g].tolist(),
                       "rgba": [int(round(255 * c)) for c in model.geom_rgba[g]]})
    return shapes


def moving_parts(model, root: int, hinge_signals: dict[str, tuple[str, int]]) -> list[dict]:
    """Every body below body `root`, parents first, as {entity, pos, quat, hinge, shapes}.

    entity: the body names from below `root` joined by "/"; pos, quat: the body frame in its
    parent's at joint angle 0 (qpos0); hinge: None, or {axis, anchor (in the body frame), signal,
    column} for a hinge joint named in `hinge_signals` (joint name -> (recorded signal key,
    column holding its angle [rad])). Joints not named there are drawn at qpos0.
    """
    names, parts = {root: ""}, []
    for body in range(model.nbody):
        parent = int(model.body_parentid[body])
        if body == root or parent not in names:
            continue
        name = model.body(body).name
        names[body] = f"{names[parent]}/{name}" if names[parent] else name
        hinge = None
        for j in range(model.body_jntadr[body], model.body_jntadr[body] + model.body_jntnum[body]):
            joint = model.joint(j).name
            if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE and joint in hinge_signals:
                signal, column = hinge_signals[joint]
                hinge = {"axis": model.jnt_axis[j].tolist(), "anchor": model.jnt_pos[j].tolist(),
                         "reference": float(model.qpos0[model.jnt_qposadr[j]]), "signal": signal, "column": column}
        parts.append({"entity": names[body], "pos": model.body_pos[body].tolist(),
                      "quat": model.body_quat[body].tolist(), "hinge": hinge, "shapes": body_shapes(model, body)})
    return parts


def hinge_poses(parts: list[dict], angles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Translation (N, P, 3) and quaternion (N, P, 4; w, x, y, z) of each of P hinged parts' frame
    in its parent's for hinge angles (N, P) [rad], column p the angle of part p: the body frame
    b turned by theta = angle - qpos0 about the unit hinge axis k through its anchor a, as
    MuJoCo places a hinged body. Both are linear in cos and sin of the angle, with constant
    coefficients per part: q = cos(theta/2) b + sin(theta/2) b o (0, k), and by Rodrigues'
    formula a - R_k(theta) a = (1 - cos theta)(a - k (k.a)) - sin theta (k x a), turned by b."""
    hinges = [part["hinge"] for part in parts]
    axis = np.array([hinge["axis"] for hinge in hinges], float)
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    anchor = np.array([hinge["anchor"] for hinge in hinges], float)
    body = np.array([part["quat"] for part in parts], float)
    theta = (np.asarray(angles, float) - np.array([hinge["reference"] for hinge in hinges]))[..., None]
    turned_axis = quat_mul(body, np.hstack([np.zeros((len(parts), 1)), axis]))
    quats = np.cos(theta / 2.0) * body + np.sin(theta / 2.0) * turned_axis
    radial = quat_rotate(body, anchor - axis * np.sum(axis * anchor, axis=1, keepdims=True))
    tangential = quat_rotate(body, np.cross(axis, anchor))
    translations = np.array([part["pos"] for part in parts], float) + (1.0 - np.cos(theta)) * radial \
        - np.sin(theta) * tangential
    return translations, quats
