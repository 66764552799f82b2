"""Reading a trace back (`testbed inspect`, `testbed.read`): its entities, time span and stored
result, and every recorded signal as arrays."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np

from testbed.recording.recorder import Trace
from testbed.recording.rrd_frames import read_whole_frames
from testbed.recording.trace import RESULT_ENTITY, SCALARS, SOURCE_ENTITY, TIMELINE, UNFINISHED_ERROR


def _chunks(path: Path):
    """The chunks of an `.rrd` in file order. A file without Rerun's footer (a long run, or one
    killed before its end) is read by a scan of the whole file, as `stream` does anyway: Rerun's
    warning that it has no manifest says nothing to our reader."""
    from testbed.recording.rerun_sdk import rr

    RrdReader = rr.chunk.RrdReader

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="RRD file has no footer")
        reader = RrdReader(str(path))
    return reader.stream()


def recorded_source(path: Path) -> str | None:
    """The scenario file a trace was run from (absolute path), read from the file's first chunks;
    None for a trace that records none (a run from a mapping, an older trace) or a file that is
    not a readable trace."""
    try:
        for chunk in _chunks(path):
            batch = chunk.to_record_batch()
            if str(chunk.entity_path) == f"/{SOURCE_ENTITY}":
                return str(batch.column("TextDocument:text")[0].as_py()[0])
            if TIMELINE in batch.schema.names:
                return None  # the source is flushed with the run's first static parts, before any sample
    except Exception:  # a foreign or damaged file names no source
        return None
    return None


def read_rrd(path: Path, signals: bool = False) -> dict:
    """Read back a run in one pass: entities (each with its row count: a signal's samples on
    sim_time that hold a value, as the trace gives them; an entity with no time, its rows), time span, the stored result (not recomputed),
    `cut_bytes` (of a last message cut short, testbed.recording.rrd_frames) and `finished`: False
    for the trace of a run that stopped before its end (killed: its stored result is the
    placeholder, or a message was cut); with `signals`, also "trace": every recorded signal as a
    `Trace` (times to the nanosecond the file stores)."""
    info, cut = read_whole_frames(path, lambda p: _read_rrd(p, signals))
    unfinished = not isinstance(info["result"], dict) or info["result"].get("error") == UNFINISHED_ERROR
    return info | {"cut_bytes": cut, "finished": cut == 0 and not unfinished}


def _read_rrd(path: Path, signals: bool) -> dict:
    static: dict[str, int] = {}  # rows without a time, per entity
    timed: dict[str, int] = {}  # rows on sim_time that hold a value, per entity
    parts: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {}
    t_min, t_max = np.inf, -np.inf
    result = None
    for chunk in _chunks(path):
        entity = str(chunk.entity_path)
        if entity.startswith("/__"):
            continue
        batch = chunk.to_record_batch()
        if TIMELINE not in batch.schema.names:
            static[entity] = static.get(entity, 0) + batch.num_rows
        else:
            times = batch.column(TIMELINE).cast("int64").to_numpy()
            if len(times):
                t_min, t_max = min(t_min, times.min() / 1e9), max(t_max, times.max() / 1e9)
            rows = batch.num_rows
            if SCALARS in batch.schema.names:
                values = batch.column(SCALARS).flatten().to_numpy(zero_copy_only=False).reshape(batch.num_rows, -1)
                rows = int(np.count_nonzero(~np.all(np.isnan(values), axis=1)))  # as `_trace` keeps them
                if signals:
                    parts.setdefault(entity.lstrip("/"), []).append((times / 1e9, values))
            timed[entity] = timed.get(entity, 0) + rows
        if entity == f"/{RESULT_ENTITY}" and batch.num_rows:
            # the last row written: a run that stops before its first flush has its "did not
            # finish" placeholder and its result in one chunk
            result = json.loads(batch.column("TextDocument:text")[batch.num_rows - 1].as_py()[0])
    if result is None:
        raise ValueError(f"{path}: no {RESULT_ENTITY} entity: not a testbed run")
    span = [float(t_min), float(t_max)] if np.isfinite(t_min) else [0.0, 0.0]
    # a signal counts its samples, as testbed.read gives them; an entity with no time its rows
    entities = {entity: timed[entity] if entity in timed else static[entity] for entity in {**static, **timed}}
    info = {"entities": entities, "time_span_s": span, "result": result}
    return info | {"trace": _trace(parts)} if signals else info


def _trace(parts: dict[str, list[tuple[np.ndarray, np.ndarray]]]) -> Trace:
    """Each signal's chunks in time order, rows that are NaN throughout (a run cut short) left out."""
    signals = {}
    for key, chunks in parts.items():
        t = np.concatenate([c[0] for c in chunks])
        v = np.concatenate([c[1] for c in chunks])
        order = np.argsort(t, kind="stable")
        t, v = t[order], v[order]
        keep = ~np.all(np.isnan(v), axis=1)
        signals[key] = (t[keep], v[keep])
    return Trace(signals)


def read_signals(path: Path) -> Trace:
    """Every recorded signal of an `.rrd` written by `TraceWriter`, as a `Trace` (`read_rrd`'s)."""
    return read_rrd(path, signals=True)["trace"]
