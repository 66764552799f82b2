"""Min/max decimation of a trace (`sim.trace_envelope_s`): each signal kept as its smallest and
largest value over blocks of samples, so a long run's file stays small and no peak is lost."""

from __future__ import annotations

import numpy as np

from testbed.recording.recorder import Chunk


def _blocks(chunk, rows: int) -> np.ndarray:
    """Indices (in the chunk) of the first sample of each block of `rows` run samples it holds;
    blocks are counted from the run's first sample, so a chunk boundary may cut one in two."""
    block = (chunk.first_row + np.arange(len(chunk.time))) // rows
    return np.flatnonzero(np.r_[True, block[1:] != block[:-1]]) if len(block) else block


def minmax_decimate(chunk, rows: int) -> tuple[np.ndarray, dict, dict]:
    """The min/max decimation of a chunk's signals over blocks of `rows` samples (`_blocks`): times (2 m,)
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
    """The chunk's samples at the first sample of each block (`_blocks`): the 3D scene of a decimated trace."""
    keep = _blocks(chunk, rows)
    return Chunk(chunk.first_row, chunk.time[keep], {key: values[keep] for key, values in chunk.signals.items()})
