"""Write a run to a Rerun 0.41 `.rrd`: every recorded signal, a 3D scene, a blueprint, the result.

Entity paths: `<group>/<signal>` for every recorded signal (groups `truth`, `sensor`,
`estimator`, `law`, `allocator`, `reference`), `world/bus` (attitude as a transform with the
bus box), `world/angular_momentum` (total, world frame), `world/bus/<name>` for each
body-frame momentum the plant's scene names (e.g. an actuator cluster's) and `run/result` (the metrics and checks as JSON, read back by
`testbed inspect`). Signals are sent with `send_columns` on `sim_time`, a chunk of samples at a
time as the run goes (`TraceWriter`).

A plant's scene may add (testbed.scene builds them from the compiled model):
- `moving_parts`: bodies on the bus, drawn at `world/bus/<body>/<child>...`, each a transform
  (turning with its hinge's recorded angle, or fixed), its geoms as `.../boxes` and
  `.../cylinders`, and optional momentum `arrows` in its frame as `.../momentum`;
- `momentum_space`: a second 3D view at `momentum_space/`: point-cloud `surfaces` (name, points
  (m, 3), color), the recorded `path` signal as `momentum_space/path/<k>` (one strip a chunk,
  segments coloured by the recorded `measure` over `measure_range`: red low, green high) and
  its current value as `momentum_space/now`.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import uuid
import warnings
from pathlib import Path

import numpy as np

# A trace written without Rerun's footer (a long run, `recording_to`) is our documented choice:
# silence the warning Rerun prints for each such file, unless the user set RUST_LOG; and a viewer
# that goes away mid-run is said once at the end (testbed.live_view), not once a flush by Rerun's
# gRPC client; a file sink's write error (a full disk) is said once by testbed.rrd_file, naming
# the file, not by Rerun's file sink and encoder. Rerun reads it once, when first imported; it is
# taken out again so that processes started later (a viewer) do not inherit it.
_SILENCED = "RUST_LOG" not in os.environ
if _SILENCED:
    os.environ["RUST_LOG"] = ("warn,re_log_encoding::rrd::file_sink=off,re_log_encoding::rrd::encoder=off,"
                              "re_grpc_client=off,re_sdk::recording_stream=off")
import rerun as rr  # noqa: E402
if _SILENCED:
    del os.environ["RUST_LOG"]
import rerun.blueprint as rrb

from testbed.atomic_file import partial_beside, publish
from testbed.errors import InputError, quoted
from testbed.recorder import Chunk, Trace
from testbed.rrd_file import FileStream
from testbed.rrd_frames import read_whole_frames
from testbed.scene import hinge_poses

APP_ID = "gyrodyne-testbed"
RESULT_ENTITY = "run/result"
TIMELINE = "sim_time"
# A run of more trace samples than this is written without Rerun's footer (recording_to):
# 10 000 s of cmg_open_loop at its 0.1 s trace period
FOOTER_MAX_SAMPLES = 100_000
SCALARS = "Scalars:scalars"
# the stored result of a run until it finishes (TraceWriter): what a trace left by a killed run says
UNFINISHED_ERROR = "the run did not finish: this trace holds the chunks written before it stopped"
NAME_MAX = 255  # bytes in one file or folder name (ext4 and most others)

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


def _series_names(name: str, width: int, units: dict) -> list[str]:
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
MOMENTUM_SPACE = "momentum_space"


def _blueprint(keys, t_end: float, scene: dict | None, path=None) -> rrb.Blueprint:
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
    space = (scene or {}).get("momentum_space")
    if space is not None:
        eye = 2.3 * _extent(space) * _side_view(np.zeros((1, 3)) if path is None else path)
        left.append(rrb.Spatial3DView(origin=f"/{MOMENTUM_SPACE}", name=space.get("title", "momentum"),
                                      eye_controls=rrb.EyeControls3D(position=eye, look_target=[0, 0, 0],
                                                                     eye_up=[0, 0, 1])))
        plots = rrb.Vertical(plots, rrb.TextDocumentView(origin="/run/summary", name="result"), row_shares=[3, 1])
    else:
        left.append(rrb.TextDocumentView(origin="/run/summary", name="result"))
    return rrb.Blueprint(
        rrb.Horizontal(rrb.Vertical(*left, row_shares=[3, 2][: len(left)] if space is None else [1, 1]), plots,
                       column_shares=[2, 3]),
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


class TraceWriter:
    """A run streamed to a Rerun recording chunk by chunk (`write`), then its result (`finish`).

    Each chunk goes out with `send_columns` on `sim_time` and is flushed, so that a file sink
    holds every chunk written so far if the process dies (SIGKILL included); until `finish`
    the stored `run/result` says the run did not finish. `scene` may hold `bus_half_size` (3,)
    [m] and a `momentum_scale` [m per N m s] for the arrows, `body_momenta` {signal key: entity
    name} of body-frame momenta to draw on the bus, and `units` {signal name: unit} beside UNITS.
    `envelope_rows` > 1: each signal is written as its envelope over blocks of that many samples
    (`envelope`, entities `<key>/min` and `<key>/max`) and the 3D scene at each block's first
    sample, so that a very long run gives a trace a viewer can open (docs/trace.md "Long runs").
    """

    def __init__(self, rec, scenario_name: str, end_time: float, scene: dict | None = None, envelope_rows: int = 1):
        self.rec, self.end_time, self.scene, self.envelope_rows = rec, end_time, scene, envelope_rows
        self.units = UNITS | (scene or {}).get("units", {})
        self.keys: dict[str, None] = {}  # every signal written, in order
        self.path_end = None  # the momentum-space path's last point and colour, to join the next chunk's strip
        space = (scene or {}).get("momentum_space")
        self.path_radius = 0.003 * _extent(space) if space else None  # once: the surfaces hold many points
        self.strips = 0
        unfinished = {"scenario": scenario_name, "sim_s": 0.0, "wall_s": 0.0, "status": "error",
                      "error": UNFINISHED_ERROR,
                      "metrics": {}, "checks": []}
        self._log_result(unfinished)
        if scene is not None:
            _write_scene_static(rec, scene)
        rec.flush()  # from now on the file is a readable, unfinished run, whatever ends the process

    def write(self, chunk) -> None:
        """Send one chunk's signals (and the 3D scene at its samples), then flush it out."""
        rec = self.rec
        new = [key for key in chunk.signals if key not in self.keys]
        if self.envelope_rows > 1:
            self._write_envelope(chunk, new)
            chunk = block_starts(chunk, self.envelope_rows)
        times = rr.TimeColumn(TIMELINE, duration=chunk.time)
        if self.envelope_rows == 1:
            for key, values in chunk.signals.items():
                values = np.asarray(values, float).reshape(len(chunk.time), -1)
                if key in new:
                    name = key.rsplit("/", 1)[-1]
                    rec.log(key, rr.SeriesLines(names=_series_names(name, values.shape[1], self.units)), static=True)
                rec.send_columns(key, indexes=[times], columns=rr.Scalars.columns(scalars=values))
        if self.scene is not None and len(chunk.time):
            _write_scene(rec, chunk, times, self.scene)
            if "momentum_space" in self.scene:
                self._write_path(chunk, times, self.scene["momentum_space"])
        if new:
            self.keys.update(dict.fromkeys(new))
            space = (self.scene or {}).get("momentum_space")
            path = chunk.signals.get(space["path"]) if space else None
            rec.send_blueprint(_blueprint(self.keys, self.end_time, self.scene, path))
        rec.flush()

    def _write_envelope(self, chunk, new: list[str]) -> None:
        """Each signal's envelope over the chunk's blocks as `<key>/min` and `<key>/max`."""
        times, low, high = envelope(chunk, self.envelope_rows)
        times = rr.TimeColumn(TIMELINE, duration=times)
        for key in chunk.signals:
            name = key.rsplit("/", 1)[-1]
            for side, values in (("min", low[key]), ("max", high[key])):
                if key in new:
                    names = [f"{n} {side}" for n in _series_names(name, values.shape[1], self.units)]
                    self.rec.log(f"{key}/{side}", rr.SeriesLines(names=names), static=True)
                self.rec.send_columns(f"{key}/{side}", indexes=[times], columns=rr.Scalars.columns(scalars=values))

    def _write_path(self, chunk, times, space: dict) -> None:
        """The momentum-space path of a chunk (one static strip a chunk, joined to the last) and its current point."""
        if space["path"] not in chunk.signals:
            return
        path = np.asarray(chunk.signals[space["path"]], float)
        measure = np.asarray(chunk.signals[space["measure"]], float).reshape(len(path), -1)[:, 0] \
            if space.get("measure") in chunk.signals else np.full(len(path), np.nan)
        colors = measure_colors(measure, space.get("measure_range", (0.0, 1.0)))
        radius = self.path_radius
        points = path if self.path_end is None else np.vstack([self.path_end, path])
        if len(points) > 1:
            self.rec.log(f"{MOMENTUM_SPACE}/path/{self.strips}",
                         rr.LineStrips3D(np.stack([points[:-1], points[1:]], axis=1), colors=colors[-(len(points) - 1):],
                                         radii=2.0 * radius), static=True)
            self.strips += 1
        self.path_end = path[-1:]
        self.rec.send_columns(f"{MOMENTUM_SPACE}/now", indexes=[times],
                              columns=rr.Points3D.columns(positions=path, colors=colors,
                                                          radii=np.full(len(path), 6.0 * radius)))

    def finish(self, result: dict) -> None:
        """Store the run's result (metrics and checks), replacing the unfinished one."""
        self._log_result(result)
        self.rec.log("run/summary", rr.TextDocument(_summary_markdown(result), media_type="text/markdown"), static=True)

    def _log_result(self, result: dict) -> None:
        self.rec.log(RESULT_ENTITY, rr.TextDocument(json.dumps(result, indent=1), media_type="text/plain"), static=True)


@contextlib.contextmanager
def recording_to(path, application: str = APP_ID, live=None, footer: bool = True):
    """A Rerun recording saved to a unique temporary file beside `path` (None: no file) and
    renamed onto it when the block ends (atomic): an interrupted write leaves nothing behind
    (the temporary file is removed on any exception, Ctrl-C and SIGTERM included), two writers
    of one path each leave a whole file, and a process killed outright (SIGKILL) leaves the
    temporary file `.<name>.<random>.partial`, readable up to its last flush. `live`: a viewer
    (testbed.live_view.ViewerStream) that gets the same stream without the file ever waiting
    for it. `footer`: end the file with Rerun's footer, a manifest of every chunk for random
    access, which Rerun keeps in memory until the end (about 200 B a chunk, a chunk per signal
    and flush): a long run goes without it, so that its memory does not grow with its duration
    (docs/trace.md "Long runs"; `rerun rrd optimize` adds it afterwards)."""
    partial, rec = None, None
    recording_id = str(uuid.uuid4())
    try:
        if path is not None:
            # the stream before the file: a signal sent once the .partial exists cannot land in
            # the stream's constructor (a half-built stream prints a traceback when collected)
            rec = rr.RecordingStream(application, recording_id=recording_id)
            path = Path(path)
            path.parent.mkdir(parents=True, exist_ok=True)
            handle, partial = partial_beside(path)
            os.close(handle)
            rec = FileStream.opened(rec, partial, path, footer)  # before logging: nothing buffered
        if live is not None:
            from testbed.live_view import Tee

            live.open(application, recording_id)
        yield rec if live is None else Tee(rec, live)
        if rec is not None:
            rec.close()
        if partial is not None:
            publish(partial, path)
        if live is not None:
            live.close()
    except BaseException as error:
        if live is not None:
            live.close(timeout=0.0)  # an interrupted run ends at once, whatever the viewer does
        if isinstance(rec, FileStream):
            rec.close_after(error)
        elif rec is not None:  # the stream was made, its file not yet
            rec.disconnect()
        if partial is not None:
            Path(partial).unlink(missing_ok=True)  # a trace the disk could not take is removed too
        raise


def file_stem(name: str) -> str:
    """A scenario name made safe as a file name: no separators, no leading dots, no '..', at
    most 100 characters (file systems take 255 bytes, and a suffix and a temporary part follow)."""
    stem = re.sub(r"[^A-Za-z0-9._-]+", "_", name).lstrip(".")
    return stem.replace("..", "_")[:100] or "run"


def output_path(out, field: str = "--out") -> Path:
    """Where a trace may be written, checked before any run and creating nothing: not a
    directory (a trailing separator means one) or a device, not under a file, its nearest
    existing folder writable, a name the file system takes. A symlink is written through (its
    target is replaced, the link stays)."""
    text = str(out)
    if not text:  # Path("") is the current folder
        raise InputError(field, "is empty; give a file name such as run.rrd")
    try:
        path = Path(text).expanduser()
        if text.endswith(("/", os.sep)) or path.is_dir():
            raise InputError(field, f"{quoted(text)} is a directory; give a file name such as run.rrd")
        if path.exists() and not path.is_file():
            raise InputError(field, f"{quoted(text)} is not a regular file")
        path = path.resolve(strict=False)
        check_creatable(path, field)
    except OSError as exc:
        raise InputError(field, f"cannot write {quoted(text)}: {exc.strerror}") from None
    except (RuntimeError, ValueError) as exc:  # a symlink loop, a NUL byte in the name
        raise InputError(field, f"cannot write {quoted(text)}: {exc}") from None
    return path


def check_creatable(path: Path, field: str) -> None:
    """`path` (absolute) can be created without creating anything now: every name fits the file
    system (NAME_MAX bytes, no NUL), its nearest existing folder is a folder and writable."""
    for part in path.parts[1:]:
        if len(part.encode()) > NAME_MAX or "\0" in part:
            raise InputError(field, f"{quoted(part)} is not a name the file system takes (at most {NAME_MAX} bytes)")
    existing = next(a for a in [path.parent, *path.parent.parents] if a.exists())
    if not existing.is_dir():
        raise InputError(field, f"{quoted(str(existing))} is a file, so {quoted(str(path))} cannot be created")
    # the one sure test: create (and remove) the kind of temporary file the trace is written to
    handle, probe = partial_beside(existing / path.name)
    os.close(handle)
    os.unlink(probe)


def _blocks(chunk, rows: int) -> np.ndarray:
    """Indices (in the chunk) of the first sample of each block of `rows` run samples it holds;
    blocks are counted from the run's first sample, so a chunk boundary may cut one in two."""
    block = (chunk.first_row + np.arange(len(chunk.time))) // rows
    return np.flatnonzero(np.r_[True, block[1:] != block[:-1]]) if len(block) else block


def envelope(chunk, rows: int) -> tuple[np.ndarray, dict, dict]:
    """The envelope of a chunk's signals over blocks of `rows` samples (`_blocks`): times (2 m,)
    [s], each block's first and last sample time, and {key: (2 m, width)} the smallest and the
    largest value of each component over the block, repeated at both times (NaN samples left
    out; NaN where a block has none). Every sample lies between the two over its block."""
    starts = _blocks(chunk, rows)
    ends = np.r_[starts[1:], len(chunk.time)] - 1
    times = np.column_stack([chunk.time[starts], chunk.time[ends]]).ravel()
    low, high = {}, {}
    with np.errstate(all="ignore"):
        for key, values in chunk.signals.items():
            values = np.asarray(values, float).reshape(len(chunk.time), -1)
            low[key] = np.repeat(np.fmin.reduceat(values, starts, axis=0), 2, axis=0)
            high[key] = np.repeat(np.fmax.reduceat(values, starts, axis=0), 2, axis=0)
    return times, low, high


def block_starts(chunk, rows: int):
    """The chunk's samples at the first sample of each block (`_blocks`): the 3D scene of an enveloped trace."""
    keep = _blocks(chunk, rows)
    return Chunk(chunk.first_row, chunk.time[keep], {key: values[keep] for key, values in chunk.signals.items()})


def _write_scene_static(rec, scene: dict) -> None:
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
        radius = 0.003 * _extent(space)
        for surface in space["surfaces"]:
            rec.log(f"{MOMENTUM_SPACE}/{surface['name']}",
                    rr.Points3D(np.asarray(surface["points"], float), colors=[surface["color"]], radii=radius), static=True)


def _momentum_scale(scene: dict) -> float:
    """Metres of arrow per N m s: arrows about twice the bus size, so they stick out of the box."""
    half = np.asarray(scene.get("bus_half_size", [0.5, 0.5, 0.5]), float)
    return float(scene.get("momentum_scale", 1.0)) * 2.0 * float(half.max())


def _write_scene(rec, chunk, times, scene: dict) -> None:
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
    """One moving part (testbed.scene.moving_parts): its frame when no hinge turns it, its geoms,
    its momentum arrows (the hinged frames follow their signals chunk by chunk, `_write_scene`)."""
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


def _extent(space: dict) -> float:
    """The largest distance from the origin of a momentum view's surfaces (its size)."""
    return max((float(np.max(np.linalg.norm(np.asarray(s["points"], float), axis=1)))
                for s in space["surfaces"] if len(s["points"])), default=1.0)


def measure_colors(values: np.ndarray, value_range) -> np.ndarray:
    """RGB (N, 3) for values over [low, high]: red at low, yellow half way, green at high."""
    low, high = value_range
    f = np.clip((np.asarray(values, float) - low) / (high - low), 0.0, 1.0)
    f = np.nan_to_num(f, nan=0.0)
    return np.column_stack([255 * np.minimum(1.0, 2.0 * (1.0 - f)), 255 * np.minimum(1.0, 2.0 * f),
                            np.full_like(f, 40.0)]).astype(np.uint8)


def _summary_markdown(result: dict) -> str:
    lines = [f"# {result.get('scenario', '')}", "", f"status: **{result.get('status', '')}**", ""]
    if result.get("error"):
        lines += [f"error: {result['error']}", ""]
    if result.get("checks"):
        lines += ["| check | value | limit | passed |", "|---|---|---|---|"]
        lines += [f"| {c['name']} | {c['value']:.4g} | {c['limit']} | {c['passed']} |" for c in result["checks"]]
    lines += ["", "| metric | value |", "|---|---|"]
    lines += [f"| {k} | {v:.6g} |" for k, v in result.get("metrics", {}).items()]
    return "\n".join(lines)


def _chunks(path: Path):
    """The chunks of an `.rrd` in file order. A file without Rerun's footer (a long run, or one
    killed before its end) is read by a scan of the whole file, as `stream` does anyway: Rerun's
    warning that it has no manifest says nothing to our reader."""
    from rerun.chunk import RrdReader

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="RRD file has no footer")
        reader = RrdReader(str(path))
    return reader.stream()


def read_rrd(path: Path) -> dict:
    """Read back a run: entities, time span, the stored result (not recomputed), `cut_bytes` (of a
    last message cut short, testbed.rrd_frames) and `finished`: False for the trace of a run that
    stopped before its end (killed: its stored result is the placeholder, or a message was cut)."""
    info, cut = read_whole_frames(path, _read_rrd)
    unfinished = not isinstance(info["result"], dict) or info["result"].get("error") == UNFINISHED_ERROR
    return info | {"cut_bytes": cut, "finished": cut == 0 and not unfinished}


def _read_rrd(path: Path) -> dict:
    entities: dict[str, int] = {}
    t_min, t_max = np.inf, -np.inf
    result = None
    for chunk in _chunks(path):
        entity = str(chunk.entity_path)
        if entity.startswith("/__"):
            continue
        batch = chunk.to_record_batch()
        entities[entity] = entities.get(entity, 0) + batch.num_rows
        if TIMELINE in batch.schema.names:
            column = batch.column(TIMELINE).cast("int64").to_numpy()
            if len(column):
                t_min, t_max = min(t_min, column.min() / 1e9), max(t_max, column.max() / 1e9)
        if entity == f"/{RESULT_ENTITY}" and batch.num_rows:
            # the last row written: a run that stops before its first flush has its "did not
            # finish" placeholder and its result in one chunk
            result = json.loads(batch.column("TextDocument:text")[batch.num_rows - 1].as_py()[0])
    if result is None:
        raise ValueError(f"{path}: no {RESULT_ENTITY} entity: not a testbed run")
    span = [float(t_min), float(t_max)] if np.isfinite(t_min) else [0.0, 0.0]
    return {"entities": entities, "time_span_s": span, "result": result}


def read_signals(path: Path) -> Trace:
    """Every recorded signal of an `.rrd` written by `TraceWriter`, as a `Trace` (times to the
    nanosecond the file stores; a file cut mid-message up to its last whole one)."""
    return read_whole_frames(path, _read_signals)[0]


def _read_signals(path: Path) -> Trace:
    parts: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {}
    for chunk in _chunks(path):
        entity = str(chunk.entity_path).lstrip("/")
        batch = chunk.to_record_batch()
        if SCALARS not in batch.schema.names or TIMELINE not in batch.schema.names:
            continue
        column = batch.column(SCALARS)
        values = column.flatten().to_numpy(zero_copy_only=False).reshape(batch.num_rows, -1)
        times = batch.column(TIMELINE).cast("int64").to_numpy() / 1e9
        parts.setdefault(entity, []).append((times, values))
    signals = {}
    for key, chunks in parts.items():
        t = np.concatenate([c[0] for c in chunks])
        v = np.concatenate([c[1] for c in chunks])
        order = np.argsort(t, kind="stable")
        t, v = t[order], v[order]
        keep = ~np.all(np.isnan(v), axis=1)
        signals[key] = (t[keep], v[keep])
    return Trace(signals)
