"""Reading a trace back (`testbed inspect`, `testbed.read`): its entities, time span and stored
result, and every recorded signal as arrays."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np

from testbed.recording.recorder import Trace
from testbed.recording.rrd_frames import read_whole_frames
from testbed.recording.trace import RESULT_ENTITY, SCALARS, TIMELINE, UNFINISHED_ERROR


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
    last message cut short, testbed.recording.rrd_frames) and `finished`: False for the trace of a
    run that stopped before its end (killed: its stored result is the placeholder, or a message
    was cut)."""
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
