"""The Rerun blueprint of a trace: one time-series view per group of signals (truth, reference,
each pipeline slot), their units and component labels, and the 3D and momentum-space views."""

from __future__ import annotations

import numpy as np
import rerun.blueprint as rrb

from testbed.recording.orbit_drawing import ORBIT_SIGNAL, ORBIT_SPACE
from testbed.recording.scene_drawing import MOMENTUM_SPACE, extent

RESULT_ENTITY = "run/result"  # where the writer stores the run's result; the layout shows it

# Unit and component labels by signal name; a signal not listed is plotted unlabelled.
UNITS = {
    "omega": "rad/s", "omega_error": "rad/s", "y": "rad/s", "bias": "rad/s",
    "quat": "", "attitude_error": "rad",
    "angular_momentum_world": "N m s", "internal_momentum": "N m s",
    "kinetic_energy": "J", "torque": "N m", "body_torque": "N m", "torque_delivered": "N m",
    "gimbal_angle": "rad", "gimbal_rate": "rad/s", "gimbal_rates": "rad/s", "rotor_rate": "rad/s",
    "singularity": "", "scale": "", "z": "rad/s",
}
AXES = {3: ["x", "y", "z"], 4: ["1", "2", "3", "4"]}


def series_names(name: str, width: int, units: dict) -> list[str]:
    unit = units.get(name, "")
    suffix = f" [{unit}]" if unit else ""
    if name == "quat":
        labels = ["w", "x", "y", "z"]
    else:
        labels = AXES.get(width, [str(i + 1) for i in range(width)])
    if width == 1:
        return [f"{name}{suffix}"]
    return [f"{name}_{label}{suffix}" for label in labels]


GROUP_ORDER = ["truth", "reference", "sensor", "estimator", "law", "allocator"]


def blueprint(keys, t_end: float, scene: dict | None, path=None) -> rrb.Blueprint:
    """The default layout: the 3D scene and the result on the left, a tab of plots per group
    (`keys`: the signals), each over the whole run [0, t_end] s; `path`: the momentum-space
    path recorded so far (the view looks at it side-on)."""
    groups: dict[str, list[str]] = {}
    for key in sorted(keys, key=lambda k: (GROUP_ORDER.index(k.split("/")[0])
                                                     if k.split("/")[0] in GROUP_ORDER else 99, k)):
        groups.setdefault(key.split("/")[0], []).append(key)
    # Every plot shows the whole run (not a window around the time cursor), legend out of the way.
    whole_run = rrb.TimeAxis(view_range=rrb.TimeRange(start=rrb.TimeRangeBoundary.absolute(seconds=0.0),
                                                      end=rrb.TimeRangeBoundary.absolute(seconds=t_end)))
    tabs = [rrb.Grid(*[rrb.TimeSeriesView(origin=f"/{key}", name=key, axis_x=whole_run,
                                          plot_legend=rrb.PlotLegend(rrb.Corner2D.RightTop)) for key in keys],
                     name=group)
            for group, keys in groups.items()]
    plots = rrb.Tabs(*tabs) if tabs else rrb.TextDocumentView(origin=f"/{RESULT_ENTITY}")
    left = []
    if scene is not None:
        # Look at the bus from outside, from a (1, -1.2, 0.8) direction, z up.
        eye = 2.5 * max(scene.get("bus_half_size", [0.5])) * np.array([1.0, -1.2, 0.8])
        left.append(rrb.Spatial3DView(origin="/world", name="attitude and momentum",
                                      eye_controls=rrb.EyeControls3D(position=eye, look_target=[0, 0, 0],
                                                                     eye_up=[0, 0, 1])))
    if ORBIT_SIGNAL in keys:  # a run in orbit: the Earth, the orbit and the bus on it
        left.append(rrb.Spatial3DView(origin=f"/{ORBIT_SPACE}", name="orbit (ECI, Mm)"))
    space = (scene or {}).get("momentum_space")
    if space is not None:
        eye = 2.3 * extent(space) * _side_view(np.zeros((1, 3)) if path is None else path)
        left.append(rrb.Spatial3DView(origin=f"/{MOMENTUM_SPACE}", name=space.get("title", "momentum"),
                                      eye_controls=rrb.EyeControls3D(position=eye, look_target=[0, 0, 0],
                                                                     eye_up=[0, 0, 1])))
        plots = rrb.Vertical(plots, rrb.TextDocumentView(origin="/run/summary", name="result"), row_shares=[3, 1])
    else:
        left.append(rrb.TextDocumentView(origin="/run/summary", name="result"))
    return rrb.Blueprint(
        rrb.Horizontal(rrb.Vertical(*left, row_shares=_shares(len(left), space is None)), plots,
                       column_shares=[2, 3]),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", play_state="following"),  # opens on the run's end
    )


def _shares(views: int, result_below: bool) -> list[int]:
    """Heights of the left column's views: the 3D scene 3 to the result's 2 (or the scene and the
    momentum space alike); an orbit view as tall as the first."""
    shares = [3, 2][:views] if result_below else [1, 1]
    return shares[:1] * (views - len(shares)) + shares


def _side_view(path: np.ndarray) -> np.ndarray:
    """A unit eye direction that sees a recorded 3D path side-on: perpendicular to its farthest
    point's direction, raised 30 deg (from (1, -1.2, 0.8) when the path stays at the origin)."""
    farthest = path[np.argmax(np.linalg.norm(path, axis=1))] if len(path) else np.zeros(3)
    if np.linalg.norm(farthest) == 0.0:
        return np.array([1.0, -1.2, 0.8]) / np.linalg.norm([1.0, -1.2, 0.8])
    side = np.cross(farthest, [0.0, 0.0, 1.0])
    if np.linalg.norm(side) < 1e-6 * np.linalg.norm(farthest):  # a path along z: look along x
        side = np.array([1.0, 0.0, 0.0])
    side = side / np.linalg.norm(side)
    return np.cos(np.radians(30)) * side + np.sin(np.radians(30)) * np.array([0.0, 0.0, 1.0])
