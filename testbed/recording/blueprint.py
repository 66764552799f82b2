"""The Rerun blueprint of a trace: the 3D views on the left; on the right one tab per subsystem
(TABS: attitude, cluster, orbit and environment, sensors and estimator, law and steering) of
time-series views, two columns wide, each titled with its signal and unit and every series
labelled with its unit, and a result tab (the stored result, whole), which it opens on."""

from __future__ import annotations

import numpy as np
from testbed.recording.rerun_sdk import rrb

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
    "gimbal_rate_command": "rad/s", "orbit_position": "m", "orbit_velocity": "m/s", "magnetic_field": "T",
    "magnetometer": "T", "magnetorquer_dipole": "A m^2", "omega_estimate": "rad/s", "target_omega": "rad/s",
    "innovation": "rad/s", "error_angle": "rad", "held_momentum": "N m s", "momentum": "N m s",
}
AXES = {3: ["x", "y", "z"], 4: ["1", "2", "3", "4"]}


def signal_unit(name: str, units: dict) -> str:
    """A signal's unit: from `units`, or N m for any torque ("" when unknown or dimensionless)."""
    return units.get(name) or ("N m" if name.startswith("torque") else "")


def series_names(name: str, width: int, units: dict) -> list[str]:
    """The legend labels of a signal's components, each with its unit: `x [rad/s]` (the view's
    title names the signal), `w`..`z` of a quaternion, `gimbal 1`.. of a gimbal or rotor signal."""
    unit = signal_unit(name, units)
    suffix = f" [{unit}]" if unit else ""
    if name.startswith("quat"):
        labels = ["w", "x", "y", "z"]
    elif name.startswith(("gimbal", "rotor")):  # one column a unit of the cluster
        labels = [f"{name.split('_')[0]} {i + 1}" for i in range(width)]
    else:
        labels = AXES.get(width, [str(i + 1) for i in range(width)])
    if width == 1:
        return [f"{name}{suffix}"]
    return [f"{label}{suffix}" for label in labels]


RESULT_TAB = "result"
TABS = ("attitude", "cluster", "orbit and environment", "sensors and estimator", "law and steering")
# The tab of a pipeline group's signals; a truth signal's by its name (CLUSTER_SIGNALS and the
# momenta the plant's scene declares, the orbit's and the environment's), else attitude; a group
# of a plug-in's own, a tab of its name.
GROUP_TABS = {"truth": "attitude", "reference": "attitude", "sensor": "sensors and estimator",
              "estimator": "sensors and estimator", "law": "law and steering", "allocator": "law and steering"}
CLUSTER_SIGNALS = {"gimbal_angle", "gimbal_rate", "gimbal_rate_command", "rotor_rate",
                   "internal_momentum", "singularity_measure", "envelope_share"}
ORBIT_ENVIRONMENT_SIGNALS = {"orbit_position", "orbit_velocity", "quat_lvlh", "eclipse", "sun_direction",
                             "moon_direction", "magnetic_field", "magnetorquer_dipole"}


def tab_of(key: str, held_momenta=frozenset()) -> str:
    """The tab a signal `group/name` is plotted in (module doc); `held_momenta`: the truth
    signals the plant's scene declares as momenta its devices hold (`body_momenta`)."""
    group, name = key.split("/", 1)
    if group == "truth":
        if name in CLUSTER_SIGNALS or key in held_momenta:
            return "cluster"
        if name in ORBIT_ENVIRONMENT_SIGNALS or name.startswith("torque_"):
            return "orbit and environment"
        if name == "magnetometer":
            return "sensors and estimator"
    return GROUP_TABS.get(group, group)


def unit_title(key: str, units: dict) -> str:
    """A view's title: the signal's name and unit, `omega [rad/s]` (`reference/omega_error [rad/s]`
    outside the truth)."""
    group, name = key.split("/", 1)
    unit = signal_unit(name, units)
    return (name if group == "truth" else key) + (f" [{unit}]" if unit else "")


def blueprint(keys, t_end: float, scene: dict | None, path=None, spectra: dict | None = None) -> rrb.Blueprint:
    """The default layout (module doc): `keys` the signals, each plotted over the whole run
    [0, t_end] s; `path`: the momentum-space path recorded so far (the view looks at it side-on);
    `spectra`: entity -> title of the spectra written after the run, as bar charts in a tab of their own."""
    units = UNITS | (scene or {}).get("units", {})
    held = frozenset((scene or {}).get("body_momenta", {}))
    tabs: dict[str, list[str]] = {}
    for key in sorted(keys, key=lambda k: (TABS.index(tab_of(k, held)) if tab_of(k, held) in TABS else len(TABS),
                                           list(GROUP_TABS).index(k.split("/")[0]) if k.split("/")[0] in GROUP_TABS
                                           else len(GROUP_TABS), k)):
        tabs.setdefault(tab_of(key, held), []).append(key)
    # Every plot shows the whole run (not a window around the time cursor).
    whole_run = rrb.TimeAxis(view_range=rrb.TimeRange(start=rrb.TimeRangeBoundary.absolute(seconds=0.0),
                                                      end=rrb.TimeRangeBoundary.absolute(seconds=t_end)))
    plots = [rrb.Grid(*[rrb.TimeSeriesView(origin=f"/{key}", name=unit_title(key, units), axis_x=whole_run,
                                           plot_legend=rrb.PlotLegend(rrb.Corner2D.RightTop)) for key in members],
                      grid_columns=2 if len(members) > 2 else 1, name=tab)
             for tab, members in tabs.items()]
    if spectra:
        plots.append(rrb.Vertical(*[rrb.BarChartView(origin=f"/{entity}", name=title)
                                    for entity, title in spectra.items()], name="spectra"))
    result = rrb.TextDocumentView(origin="/run/summary", name=RESULT_TAB)
    right = (rrb.Tabs(*plots, result, active_tab=RESULT_TAB) if plots
             else rrb.TextDocumentView(origin=f"/{RESULT_ENTITY}"))
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
    root = rrb.Horizontal(rrb.Vertical(*left), right, column_shares=[1, 2]) if left else right
    return rrb.Blueprint(
        root,
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", play_state="following"),  # opens on the run's end
    )


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
