"""Sensor `star_tracker_gyro` on many worlds (testbed.batch): each world's instruments draw from
their own generators, in their single run's order, and the tracker's and the gyro package's
arithmetic runs on (N, ...) rows (`tracked_attitude`, `mean_rate`). Batched when the worlds share
their sampling (periods, no latency) and none quantises its gyro or excludes bright bodies;
otherwise each world runs its own sensor."""

from __future__ import annotations

import numpy as np

from testbed.math.quaternion import quat_conj, quat_mul, rotation_vector
from testbed.sensors.gyro_package import mean_rate
from testbed.sensors.star_tracker import tracked_attitude


def batchable(stages: list) -> bool:
    """Whether these worlds' sensors run as one form (module doc)."""
    first = stages[0]
    timing = (first.called, first.tracker_every, first.gyro_every)
    return all((s.called, s.tracker_every, s.gyro_every) == timing and s.delay == 0 and s.exclusion is None
               and s.gyro.step == 0 for s in stages)


class StarTrackerGyroWorlds:
    """The worlds' sensors' state stacked: the tick they share, the gyro biases, the attitudes at
    the last gyro samples and the outputs they hold between samples."""

    def __init__(self, stages: list):
        self.stages = list(stages)
        first = stages[0]
        self.tick, self.called = first.tick, first.called
        self.tracker_every, self.gyro_every = first.tracker_every, first.gyro_every
        self.bias = np.array([s.gyro.bias for s in stages])
        self.matrix = np.array([s.gyro.matrix for s in stages])
        self.period = np.array([[s.gyro.period] for s in stages])
        self.frame = np.array([s.tracker.frame for s in stages])
        self.sigma = np.array([s.tracker.sigma for s in stages])
        self.last_quat = None if first.last_quat is None else np.array([s.last_quat for s in stages])
        self.out = {key: np.array([s.out[key] for s in stages]) for key in first.out}

    def keep(self, rows) -> None:
        self.stages = [self.stages[i] for i in rows]
        for name in ("bias", "matrix", "period", "frame", "sigma"):
            setattr(self, name, getattr(self, name)[rows])
        if self.last_quat is not None:
            self.last_quat = self.last_quat[rows]
        self.out = {key: value[rows] for key, value in self.out.items()}

    def settle(self, row: int) -> None:
        """Write the row's gyro bias, tick, last attitude and held outputs back into its sensor."""
        stage = self.stages[row]
        stage.gyro.bias, stage.tick = self.bias[row].copy(), self.tick
        stage.last_quat = None if self.last_quat is None else self.last_quat[row].copy()
        stage.out = {key: value[row].copy() for key, value in self.out.items()}

    def measure(self, t, plants: list) -> dict:
        quat = np.array([plant.quat() for plant in plants])
        out, count = self.out, len(self.stages)
        if self.tick % self.gyro_every == 0:
            if self.last_quat is None:
                turn = np.array([plant.omega() for plant in plants]) * self.period
            else:
                turn = rotation_vector(quat_mul(quat_conj(self.last_quat), quat))
            self.last_quat = quat
            draws = [stage.gyro.draws() for stage in self.stages]
            step, white = (np.array([d[k] for d in draws]) for k in (0, 1))
            out["gyro_rate"], self.bias = mean_rate(self.matrix, turn, self.period, self.bias, step, white)
            out["gyro_stamp"] = np.full((count, 1), t)
            out["gyro_bias"] = self.bias.copy()
        available = np.array([[stage.tracker.available(t)] for stage in self.stages])
        fresh = available & (self.tick % self.tracker_every == 0)
        if fresh.any():
            rows = np.flatnonzero(fresh[:, 0])
            draws = np.array([self.stages[row].tracker.noise.add(0.0, 1.0, 3) for row in rows])
            out["tracker_quat"] = out["tracker_quat"].copy()
            out["tracker_quat"][rows] = tracked_attitude(quat[rows], self.frame[rows], self.sigma[rows], draws)
            out["tracker_stamp"] = np.where(fresh, t, out["tracker_stamp"])
        out["tracker_new"] = fresh.astype(float)
        out["tracker_available"] = available.astype(float)
        self.tick += 1
        return dict(out)
