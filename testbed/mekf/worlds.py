"""Estimator `mekf` on many worlds (testbed.batch): the filters of the worlds as one `Mekf` on
(N, ...) rows, each row propagated and updated as its world's own filter would be at that tick
(testbed.mekf.stage). Batched when no world's tracker is late (a latency keeps per-world queues
of gyro samples: those worlds run their own estimators)."""

from __future__ import annotations

import numpy as np

from testbed.batch.stacked_stages import failure_of
from testbed.batch.stage_forms import WorldsFailed, rows_of, stacked
from testbed.mekf.filter import Mekf


def batchable(stages: list) -> bool:
    return all(stage.latency == 0.0 and not stage.pending for stage in stages)


def rows_of_filter(f: Mekf, rows) -> Mekf:
    """The filters at `rows` of the stacked filter f, as one (their states as they are: not
    normalised again, as Mekf() would)."""
    part = object.__new__(Mekf)
    part.quat, part.bias, part.covariance = f.quat[rows], f.bias[rows], f.covariance[rows]
    part.arw, part.rrw = f.arw[rows], f.rrw[rows]
    return part


class MekfWorlds:
    """The worlds' MEKF estimators' state stacked: the filters, the times their states are at,
    whether each has its first fix, the last innovations and NIS, and the last good fix's time."""

    def __init__(self, stages: list):
        self.stages = list(stages)
        filters = [stage.filter for stage in stages]
        self.filter = Mekf(np.array([f.quat for f in filters]), np.array([f.bias for f in filters]),
                           np.array([f.covariance for f in filters]), np.array([f.arw for f in filters]),
                           np.array([f.rrw for f in filters]))
        self.noise = np.array([stage.noise for stage in stages])
        self.time = np.array([stage.time for stage in stages])
        self.fixed = np.array([stage.fixed for stage in stages])
        self.innovation = np.array([stage.innovation for stage in stages])
        self.nis = np.array([stage.nis for stage in stages])
        self.coast_bound = np.array([stage.coast_bound for stage in stages])
        self.last_fix = np.array([np.nan if stage.last_fix is None else stage.last_fix for stage in stages])

    def keep(self, rows) -> None:
        self.stages = [self.stages[i] for i in rows]
        self.filter = rows_of_filter(self.filter, rows)
        for name in ("noise", "time", "fixed", "innovation", "nis", "coast_bound", "last_fix"):
            setattr(self, name, getattr(self, name)[rows])

    def settle(self, row: int) -> None:
        """Write the row's filter, times, fix and last update back into its world's estimator."""
        stage, f = self.stages[row], self.filter
        stage.filter = rows_of_filter(f, row)
        stage.filter.arw, stage.filter.rrw = float(f.arw[row]), float(f.rrw[row])
        stage.time, stage.fixed = float(self.time[row]), bool(self.fixed[row])
        stage.innovation, stage.nis = self.innovation[row].copy(), self.nis[row].copy()
        stage.last_fix = None if np.isnan(self.last_fix[row]) else float(self.last_fix[row])

    def _apply(self, rows: np.ndarray, step) -> None:
        """Run `step(filter of those rows)` on the filters at `rows` and write them back."""
        if not len(rows):
            return
        part = self.filter if len(rows) == len(self.stages) else rows_of_filter(self.filter, rows)
        result = step(part)
        f = self.filter
        f.quat, f.bias, f.covariance = f.quat.copy(), f.bias.copy(), f.covariance.copy()
        f.quat[rows], f.bias[rows], f.covariance[rows] = part.quat, part.bias, part.covariance
        return result

    def estimate(self, t, measurement, command) -> dict:
        """The worlds' estimates at t; when a row's arithmetic overflows or its covariance turns
        singular (a raise under the single run's floating-point rules), the tick is run again
        world by world on the worlds' own estimators, from the state before it, so that the
        failing world ends as its single run does and the others go on."""
        f = self.filter
        before = (f.quat, f.bias, f.covariance, self.time.copy(), self.fixed.copy(), self.innovation, self.nis,
                  self.last_fix)
        try:
            with np.errstate(over="raise", invalid="raise", divide="raise"):
                return self._estimate(t, measurement)
        except (ArithmeticError, np.linalg.LinAlgError):
            f.quat, f.bias, f.covariance, self.time, self.fixed, self.innovation, self.nis, self.last_fix = before
            return self._each_alone(t, measurement, command)

    def _each_alone(self, t, measurement, command) -> dict:
        """This tick on each world's own estimator (written back first), the form then read again from them."""
        count = len(self.stages)
        outputs, failures = [None] * count, {}
        for row, stage in enumerate(self.stages):
            self.settle(row)
            try:
                with np.errstate(over="raise", invalid="raise", divide="raise"):
                    outputs[row] = stage.estimate(t, rows_of(measurement, count)[row], rows_of(command, count)[row])
            except Exception as exc:  # noqa: BLE001  (that world's own estimator failed: it ends that world)
                failures[row] = failure_of(t, "estimator", stage, exc)
        self.__init__(self.stages)
        alive = next((out for out in outputs if out is not None), None)
        filler = {key: np.full(np.shape(value), np.nan) for key, value in (alive or {}).items()}
        stacked_outputs = stacked([filler if out is None else out for out in outputs])
        if failures:
            raise WorldsFailed(failures, stacked_outputs)
        return stacked_outputs

    def _estimate(self, t, measurement) -> dict:
        stamp = measurement["gyro_stamp"][:, 0]
        new = measurement["tracker_new"][:, 0] != 0
        seen = measurement["tracker_stamp"][:, 0]
        rate = measurement["gyro_rate"]
        # the gyro sample since the filter's time (MekfEstimator._advance without a latency)
        moving = np.flatnonzero(self.fixed & (stamp > self.time))
        self._apply(moving, lambda part: part.propagate(rate[moving], stamp[moving] - self.time[moving]))
        self.time[moving] = stamp[moving]
        first = np.flatnonzero(new & ~self.fixed)
        if len(first):
            self.filter.quat = self.filter.quat.copy()
            self.filter.quat[first] = measurement["tracker_quat"][first]
            self.time[first], self.fixed[first] = seen[first], True
        updating = np.flatnonzero(new & self.fixed)
        updating = np.setdiff1d(updating, first)
        updated = np.zeros(len(self.stages))
        if len(updating):
            def update(part):
                z = part.innovation(measurement["tracker_quat"][updating])
                return z, part.update(z, self.noise[updating])
            z, nis = self._apply(updating, update)
            self.innovation = self.innovation.copy()
            self.nis = self.nis.copy()
            self.innovation[updating], self.nis[updating, 0] = z, nis
            updated[updating] = 1.0
        f = self.filter
        p = f.covariance
        sigma3 = 3.0 * np.sqrt(np.diagonal(p, axis1=-2, axis2=-1))
        outputs = {"quat": f.quat, "omega": rate - f.bias, "bias": f.bias, "attitude_sigma3": sigma3[:, :3],
                   "bias_sigma3": sigma3[:, 3:], "covariance": p.reshape(len(p), 36), "innovation": self.innovation,
                   "nis": self.nis, "updated": updated[:, None]}
        self._coast(t, updated, sigma3[:, :3], outputs)
        return outputs

    def _coast(self, t: float, updated: np.ndarray, sigma3: np.ndarray, outputs: dict) -> None:
        """MekfEstimator._check_coast on every row; the rows past their bound fail their worlds."""
        within = np.all(sigma3 <= self.coast_bound, axis=1)
        fixed_now = updated != 0
        self.last_fix = np.where(fixed_now, np.where(within, t, np.nan), self.last_fix)
        past = np.flatnonzero(~fixed_now & ~np.isnan(self.last_fix) & ~within)
        failures = {}
        for row in past.tolist():
            stage = self.stages[row]
            stage.last_fix = float(self.last_fix[row])
            try:
                stage._check_coast(t, 0.0, sigma3[row])
            except Exception as exc:  # noqa: BLE001  (the stage's own MethodFailed, worded as a single run's)
                failures[row] = failure_of(t, "estimator", stage, exc)
        if failures:
            raise WorldsFailed(failures, outputs)
