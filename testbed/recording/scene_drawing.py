"""Drawing a run's 3D scene into its trace: the bus, the moving parts a plant lists
(testbed.recording.scene), and the momentum-space surfaces and path."""

from __future__ import annotations

import numpy as np
from testbed.recording.rerun_sdk import rr

from testbed.recording.scene import hinge_poses

MOMENTUM_SPACE = "momentum_space"


def write_scene_static(rec, scene: dict) -> None:
    """What does not move: the bus box and axes, the moving parts' shapes, the momentum-space surfaces."""
    half = np.asarray(scene.get("bus_half_size", [0.5, 0.5, 0.5]), float)
    # a solid translucent bus, or its edges only when parts inside it are drawn
    fill = "majorwireframe" if scene.get("moving_parts") else "solid"
    rec.log("world/bus", rr.Boxes3D(half_sizes=[half], colors=[[170, 175, 190, 90]], fill_mode=fill), static=True)
    rec.log("world/bus/axes", rr.Arrows3D(vectors=np.eye(3) * 1.5 * half.max(),
                                          colors=[[220, 60, 60], [60, 200, 60], [60, 60, 220]],
                                          labels=["x", "y", "z"]), static=True)
    for part in scene.get("moving_parts", []):
        _write_part_static(rec, part, _momentum_scale(scene))
    space = scene.get("momentum_space")
    if space is not None:
        radius = 0.003 * extent(space)
        for surface in space["surfaces"]:
            rec.log(f"{MOMENTUM_SPACE}/{surface['name']}",
                    rr.Points3D(np.asarray(surface["points"], float), colors=[surface["color"]], radii=radius), static=True)


def _momentum_scale(scene: dict) -> float:
    """Metres of arrow per N m s: arrows about twice the bus size, so they stick out of the box."""
    half = np.asarray(scene.get("bus_half_size", [0.5, 0.5, 0.5]), float)
    return float(scene.get("momentum_scale", 1.0)) * 2.0 * float(half.max())


def write_scene(rec, chunk, times, scene: dict) -> None:
    """The bus attitude and the momentum arrows at a chunk's samples."""
    signals = chunk.signals
    if "truth/quat" in signals:
        q = signals["truth/quat"]
        rec.send_columns("world/bus", indexes=[times],
                         columns=rr.Transform3D.columns(quaternion=q[:, [1, 2, 3, 0]]))  # Rerun: xyzw
    scale = _momentum_scale(scene)
    arrows = [("truth/angular_momentum_world", "world/angular_momentum", [250, 200, 40])] + [
        (key, f"world/bus/{name}", [240, 110, 30]) for key, name in scene.get("body_momenta", {}).items()]
    for key, entity, color in arrows:
        if key in signals:
            vectors = signals[key] * scale
            rec.send_columns(entity, indexes=[times],
                             columns=rr.Arrows3D.columns(vectors=vectors, origins=np.zeros_like(vectors),
                                                         colors=np.tile(color, (len(vectors), 1))))
    hinged = [part for part in scene.get("moving_parts", [])
              if part["hinge"] is not None and part["hinge"]["signal"] in signals]
    if hinged:
        angles = np.column_stack([signals[part["hinge"]["signal"]][:, part["hinge"]["column"]] for part in hinged])
        translations, quats = hinge_poses(hinged, angles)
        for p, part in enumerate(hinged):
            rec.send_columns(f"world/bus/{part['entity']}", indexes=[times],
                             columns=rr.Transform3D.columns(translation=translations[:, p], quaternion=_xyzw(quats[:, p])))


def _xyzw(quat) -> np.ndarray:
    """MuJoCo's (w, x, y, z) as Rerun's (x, y, z, w), for (4,) or (N, 4)."""
    return np.asarray(quat, float)[..., [1, 2, 3, 0]]


def _write_part_static(rec, part: dict, scale: float) -> None:
    """One moving part (testbed.recording.scene.moving_parts): its frame when no hinge turns it, its geoms,
    its momentum arrows (the hinged frames follow their signals chunk by chunk, `write_scene`)."""
    entity = f"world/bus/{part['entity']}"
    if part["hinge"] is None:
        rec.log(entity, rr.Transform3D(translation=part["pos"], quaternion=_xyzw(part["quat"])), static=True)
    for kind in ("box", "cylinder"):
        shapes = [shape for shape in part["shapes"] if shape["kind"] == kind]
        if not shapes:
            continue
        common = {"centers": [sh["pos"] for sh in shapes], "quaternions": [_xyzw(sh["quat"]) for sh in shapes],
                  "colors": [sh["rgba"] for sh in shapes], "fill_mode": "solid"}
        if kind == "box":
            rec.log(f"{entity}/boxes", rr.Boxes3D(half_sizes=[sh["size"] for sh in shapes], **common), static=True)
        else:
            rec.log(f"{entity}/cylinders", rr.Cylinders3D(radii=[sh["size"][0] for sh in shapes],
                                                          lengths=[2.0 * sh["size"][1] for sh in shapes], **common),
                    static=True)
    if part.get("arrows"):
        rec.log(f"{entity}/momentum", rr.Arrows3D(vectors=[np.asarray(a["vector"], float) * scale for a in part["arrows"]],
                                                  labels=[a.get("label", "") for a in part["arrows"]], show_labels=False,
                                                  colors=[[250, 150, 60]] * len(part["arrows"])), static=True)


def extent(space: dict) -> float:
    """The largest distance from the origin of a momentum view's surfaces (its size)."""
    return max((float(np.max(np.linalg.norm(np.asarray(s["points"], float), axis=1)))
                for s in space["surfaces"] if len(s["points"])), default=1.0)


def write_marks(rec, marks: dict, path: np.ndarray, codes: np.ndarray, index: int, radius: float) -> None:
    """The path's samples where the recorded code signal is one of marks["kinds"] {code: {name, color}}, one
    static point set a kind and chunk: `momentum_space/<marks["entity"]>/<name>/<index>`."""
    codes = np.asarray(codes, float).reshape(len(path), -1)[:, 0]
    for code, kind in marks["kinds"].items():
        met = codes == float(code)
        if met.any():
            rec.log(f"{MOMENTUM_SPACE}/{marks['entity']}/{kind['name']}/{index}",
                    rr.Points3D(path[met], colors=[kind["color"]], radii=radius), static=True)


def measure_colors(values: np.ndarray, value_range) -> np.ndarray:
    """RGB (N, 3) for values over [low, high]: red at low, yellow half way, green at high."""
    low, high = value_range
    f = np.clip((np.asarray(values, float) - low) / (high - low), 0.0, 1.0)
    f = np.nan_to_num(f, nan=0.0)
    return np.column_stack([255 * np.minimum(1.0, 2.0 * (1.0 - f)), 255 * np.minimum(1.0, 2.0 * f),
                            np.full_like(f, 40.0)]).astype(np.uint8)
