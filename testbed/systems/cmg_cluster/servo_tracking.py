"""The accuracy guard's look at the gimbal servo: how far it misses what it could follow.

At each trace sample on a control instant t_k the trace holds the rate b'(t_k) and the command
c held over the tick that ends there (truth/gimbal_rate_command). The guard's figure is

    max_i max_k (|b'_i(t_k) - c_i(t_k)| - J(t_k))_+ / max(max_k |c_i(t_k)|, SCALE_FLOOR)

with J(t_k) the largest jump of any gimbal's command between consecutive samples over the
last two ticks: the servo may miss all of a jump it was just handed (the start, where the
gimbals leave rest for c(0), is one; so is a min-max flip or a noisy estimate's command), the
feedforward servo's observer meets the disturbance that jump causes one tick late, and a jump
of one gimbal shakes the others through the bus. Commands are clipped to the model's rate
limit, and a gimbal whose fault (motor_off, rate_limit) stops it following is not judged.
A command amplitude below SCALE_FLOOR_RAD_S is judged as that: an idle cluster's round-off
commands, or a zero command the servo holds on a tumbling bus against the gyroscopic torque
(docs/theory/accuracy.md, "The servo's tracking").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.systems.cmg_cluster.faults import FAULT_CODES

# 0.57 deg/s, a twentieth of the shipped allocators' 10 deg/s: under it the default 5 % is a
# miss of 5e-4 rad/s (the zero command on a bus tumbling at 0.5 deg/s is missed by 7e-6 rad/s)
SCALE_FLOOR_RAD_S = 0.01
NOT_FOLLOWING = (FAULT_CODES["motor_off"], FAULT_CODES["rate_limit"])


@dataclass(frozen=True)
class ServoMiss:
    """The running reduction of the module docstring: state (command peak, miss peak, the last
    two judged command rows); `control_period` [s] picks the samples at control instants,
    `rate_limit` [rad/s] (None: none) clips the command as the servo does."""

    control_period: float
    rate_limit: float | None = None

    def start(self):
        return None, None, None

    def update(self, state, chunk):
        if "truth/gimbal_rate" not in chunk.signals or len(chunk.time) == 0:
            return state
        ticks = chunk.time / self.control_period
        on_tick = np.abs(ticks - np.round(ticks)) < 1e-6 * np.maximum(1.0, ticks)
        if not on_tick.any():
            return state
        command = chunk["truth/gimbal_rate_command"][on_tick]
        if self.rate_limit is not None:
            command = np.clip(command, -self.rate_limit, self.rate_limit)
        rate = chunk["truth/gimbal_rate"][on_tick]
        command_peak, miss_peak, before = state
        rows = command if before is None else np.vstack([before, command])
        jumps = np.zeros(len(rows))
        jumps[1:] = np.max(np.abs(np.diff(rows, axis=0)), axis=1)  # any gimbal's, sample to sample
        recent = np.maximum(jumps, np.concatenate([[0.0], jumps[:-1]]))[len(rows) - len(command):]
        miss = np.maximum(np.abs(rate - command) - recent[:, None], 0.0)
        amplitude = np.abs(command)
        if "truth/fault" in chunk.signals:
            stopped = np.isin(chunk["truth/fault"][on_tick], NOT_FOLLOWING)
            miss, amplitude = np.where(stopped, 0.0, miss), np.where(stopped, 0.0, amplitude)
        command_peak = _fmax(command_peak, amplitude)
        return command_peak, _fmax(miss_peak, miss), rows[-2:].copy()

    def result(self, state):
        return state


def _fmax(peak, values):
    """The running per-gimbal maximum over rows (NaN rows skipped)."""
    chunk_peak = np.nanmax(values, axis=0)
    return chunk_peak if peak is None else np.fmax(peak, chunk_peak)


def servo_miss(state) -> float:
    """The guard's figure of the module docstring from a ServoMiss's state (NaN: nothing judged)."""
    command_peak, miss_peak, _ = state
    if miss_peak is None:
        return float("nan")
    return float(np.nanmax(miss_peak / np.maximum(command_peak, SCALE_FLOOR_RAD_S)))
