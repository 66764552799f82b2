"""Write a run to a Rerun 0.41 `.rrd`: every recorded signal, a 3D scene, a blueprint, the result.

Entity paths: `<group>/<signal>` for every recorded signal (groups `truth`, `sensor`,
`estimator`, `law`, `allocator`, `reference`), `world/bus` (attitude as a transform with the
bus box), `world/angular_momentum` (total, world frame), `world/bus/<name>` for each
body-frame momentum the plant's scene names (e.g. an actuator cluster's) and `run/result` (the metrics and checks as JSON, read back by
`testbed inspect`). Signals are sent with `send_columns` on `sim_time`, a chunk of samples at a
time as the run goes (`TraceWriter`).

A plant's scene may add (testbed.recording.scene builds them from the compiled model):
- `moving_parts`: bodies on the bus, drawn at `world/bus/<body>/<child>...`, each a transform
  (turning with its hinge's recorded angle, or fixed), its geoms as `.../boxes` and
  `.../cylinders`, and optional momentum `arrows` in its frame as `.../momentum`;
- `momentum_space`: a second 3D view at `momentum_space/`: point-cloud `surfaces` (name, points
  (m, 3), color), the recorded `path` signal as `momentum_space/path/<k>` (one strip a chunk,
  segments coloured by the recorded `measure` over `measure_range`: red low, green high) and
  its current value as `momentum_space/now`; optional `marks` {signal, entity, kinds {code: {name, color}}}:
  the path's samples where the code signal holds a kind, as points at `momentum_space/<entity>/<name>/<k>`.
"""

from __future__ import annotations

import contextlib
import json
import os
import uuid
from pathlib import Path

import numpy as np
from testbed.recording.rerun_sdk import rr

from testbed.interrupts import signals_held
from testbed.metrics import value_text
from testbed.recording.atomic_file import partial_beside, publish
from testbed.recording.blueprint import RESULT_ENTITY, UNITS, blueprint, series_names
from testbed.recording.markdown_table import markdown_table
from testbed.recording.decimation import block_starts, minmax_decimate
from testbed.recording.rrd_file import FileStream
from testbed.recording.spectra import ENTITY as SPECTRUM_ENTITY
from testbed.recording.orbit_drawing import ORBIT_SIGNAL, write_orbit, write_orbit_static
from testbed.recording.scene_drawing import (MOMENTUM_SPACE, extent, measure_colors, write_marks, write_scene,
                                             write_scene_static)

APP_ID = "gyrodyne-testbed"
TIMELINE = "sim_time"
# A run of more trace samples than this is written without Rerun's footer (recording_to):
# 10 000 s of cmg_open_loop at its 0.1 s trace period
FOOTER_MAX_SAMPLES = 100_000
SCALARS = "Scalars:scalars"
# the stored result of a run until it finishes (TraceWriter): what a trace left by a killed run says
# the absolute path of the scenario file a run came from: a default output path is not reused by another file
SOURCE_ENTITY = "run/source"
UNFINISHED_ERROR = "the run did not finish: this trace holds the chunks written before it stopped"


class TraceWriter:
    """A run streamed to a Rerun recording chunk by chunk (`write`), then its result (`finish`).

    Each chunk goes out with `send_columns` on `sim_time` and is flushed, so that a file sink
    holds every chunk written so far if the process dies (SIGKILL included); until `finish`
    the stored `run/result` says the run did not finish. `scene` may hold `bus_half_size` (3,)
    [m] and a `momentum_scale` [m per N m s] for the arrows, `body_momenta` {signal key: entity
    name} of body-frame momenta to draw on the bus, and `units` {signal name: unit} beside UNITS.
    `envelope_rows` > 1: each signal is written as its envelope over blocks of that many samples
    (`minmax_decimate`, entities `<key>/min` and `<key>/max`) and the 3D scene at each block's first
    sample, so that a very long run gives a trace a viewer can open (docs/trace.md "Long runs").
    """

    def __init__(self, rec, scenario_name: str, end_time: float, scene: dict | None = None, envelope_rows: int = 1,
                 source: str = ""):
        self.rec, self.end_time, self.scene, self.envelope_rows = rec, end_time, scene, envelope_rows
        self.units = UNITS | (scene or {}).get("units", {})
        self.keys: dict[str, None] = {}  # every signal written, in order
        self.path_end = None  # the momentum-space path's last point and colour, to join the next chunk's strip
        self.view_path = None  # the path the layout last looked at (a layout re-sent after the run keeps its view)
        space = (scene or {}).get("momentum_space")
        self.path_radius = 0.003 * extent(space) if space else None  # once: the surfaces hold many points
        self.strips = 0
        self.orbit_strips, self.orbit_end = None, None  # a run in orbit: its path so far (orbit_drawing)
        unfinished = {"scenario": scenario_name, "sim_s": 0.0, "wall_s": 0.0, "status": "error",
                      "error": UNFINISHED_ERROR,
                      "metrics": {}, "checks": []}
        self._log_result(unfinished)
        if source:  # flushed with the first static parts, so a later run reads it cheaply (trace_reader.recorded_source)
            rec.log(SOURCE_ENTITY, rr.TextDocument(str(Path(source).resolve()), media_type="text/plain"), static=True)
        if scene is not None:
            write_scene_static(rec, scene)
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
                    rec.log(key, rr.SeriesLines(names=series_names(name, values.shape[1], self.units)), static=True)
                rec.send_columns(key, indexes=[times], columns=rr.Scalars.columns(scalars=values))
        if self.scene is not None and len(chunk.time):
            write_scene(rec, chunk, times, self.scene)
            if "momentum_space" in self.scene:
                self._write_path(chunk, times, self.scene["momentum_space"])
        if ORBIT_SIGNAL in chunk.signals and len(chunk.time):
            if self.orbit_strips is None:
                write_orbit_static(rec)
            self.orbit_strips, self.orbit_end = write_orbit(rec, chunk, times, self.orbit_strips or 0, self.orbit_end)
        if new:
            self.keys.update(dict.fromkeys(new))
            space = (self.scene or {}).get("momentum_space")
            path = chunk.signals.get(space["path"]) if space else None
            self.view_path = path
            rec.send_blueprint(blueprint(self.keys, self.end_time, self.scene, path))
        rec.flush()

    def _write_envelope(self, chunk, new: list[str]) -> None:
        """Each signal's envelope over the chunk's blocks as `<key>/min` and `<key>/max`."""
        times, low, high = minmax_decimate(chunk, self.envelope_rows)
        times = rr.TimeColumn(TIMELINE, duration=times)
        for key in chunk.signals:
            name = key.rsplit("/", 1)[-1]
            for side, values in (("min", low[key]), ("max", high[key])):
                if key in new:
                    names = [f"{n} {side}" for n in series_names(name, values.shape[1], self.units)]
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
        marks = space.get("marks")
        if marks is not None and marks["signal"] in chunk.signals:
            write_marks(self.rec, marks, path, chunk.signals[marks["signal"]], self.strips, 5.0 * radius)
        self.rec.send_columns(f"{MOMENTUM_SPACE}/now", indexes=[times],
                              columns=rr.Points3D.columns(positions=path, colors=colors,
                                                          radii=np.full(len(path), 6.0 * radius)))

    def write_spectra(self, spectra: dict) -> None:
        """Each spectrum computed after the run (name -> (frequencies [Hz], values, title);
        testbed.recording.spectra) as a bar chart at `spectrum/<name>`, and the layout with their tab."""
        if not spectra:
            return
        for name, (freq, values, _) in spectra.items():
            widths = np.full(len(freq), freq[1] - freq[0] if len(freq) > 1 else 1.0)
            self.rec.log(f"{SPECTRUM_ENTITY}/{name}", rr.BarChart(values, abscissa=freq, widths=widths), static=True)
        titles = {f"{SPECTRUM_ENTITY}/{name}": title for name, (_, _, title) in spectra.items()}
        self.rec.send_blueprint(blueprint(self.keys, self.end_time, self.scene, self.view_path, titles))

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
    (testbed.recording.live_view.ViewerStream) that gets the same stream without the file ever waiting
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
            with signals_held():  # a signal between making the file and keeping its name would leave it
                handle, partial = partial_beside(path)
            os.close(handle)
            rec = FileStream.opened(rec, partial, path, footer)  # before logging: nothing buffered
        if live is not None:
            from testbed.recording.live_view import Tee

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


def _summary_markdown(result: dict) -> str:
    """The result pane: status, checks, and each metric with its one-line meaning and, where its
    value looks alarming by design, the note saying why (testbed.metrics)."""
    from testbed.metrics import caveats, meaning  # the metric registry sits above the recording

    lines = [f"# {result.get('scenario', '')}", "", f"status: **{result.get('status', '')}**", ""]
    if result.get("error"):
        lines += [f"error: {result['error']}", ""]
    if result.get("checks"):
        lines += markdown_table(["check", "value", "limit", "passed"],
                                [[c["name"], value_text(c["value"], c["limit"], c["passed"]), c["limit"], c["passed"]]
                                 for c in result["checks"]])
    values = result.get("metrics", {})
    lines += [""] + markdown_table(["metric", "value", "meaning"], [[k, f"{v:.6g}", meaning(k)] for k, v in values.items()])
    lines += [f"\n**{name}**: {caveat}" for name, caveat in caveats(values).items()]
    return "\n".join(lines)
