"""Single-axis rate gyro: y = p . w + bias + noise, quantised, sampled at its own period.

The only measurement of the Lebedev problem (Lebedev 1976, eq. 1.1). The sensing axis p is a
unit vector in body axes; a non-unit axis is refused, never normalised. Between samples the
last sample is held; `stamp` is the time the held sample was taken.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.batch.stage_forms import WorldsFailed, replayed
from testbed.math.validation import check_unit_vector
from testbed.pipeline import stage
from testbed.scenario.schema import join, param, whole_multiple
from testbed.stages.white_noise import WhiteNoise


@dataclass(kw_only=True)
class RateGyroParams:
    axis: list[float] = param(length=3, doc="unit sensing axis p, body axes")
    sample_period_s: float | None = param(None, gt=0, doc="default: the estimator period (sim.estimator_period_s)")
    noise_sigma_rad_s: float = param(0.0, ge=0, doc="white noise, standard deviation per sample")
    bias_rad_s: float = param(0.0, doc="constant bias")
    quantisation_rad_s: float = param(0.0, ge=0, doc="output step (0: none)")
    seed: int = param(0, ge=0, doc="noise seed: the same seed gives the same samples bit for bit")

    def validate(self, path: str) -> None:
        self.axis = list(check_unit_vector(self.axis, join(path, "axis")))


@stage("sensor", "rate_gyro", RateGyroParams)
class RateGyro:
    @classmethod
    def design(cls, params: RateGyroParams) -> dict:
        return {"outputs": ("y", "stamp"), "sensing_axis": list(params.axis)}

    def __init__(self, params: RateGyroParams, ctx):
        self.axis = np.asarray(params.axis, float)
        self._axis = self.axis.tolist()
        called = ctx.sample_period or ctx.control_period     # how often the pipeline calls the sensor
        period = params.sample_period_s or called
        field = "pipeline.sensor.sample_period_s"
        self.every = whole_multiple(period, ctx.dt, field, "the physics step sim.dt_s")
        multirate = called != ctx.control_period
        self.every_tick = whole_multiple(period, called, field,
                                         "sim.estimator_period_s" if multirate else "sim.control_period_s")
        self.params = params
        self.noise = WhiteNoise(params.seed)
        self.tick = 0
        self.y = np.zeros(1)
        self.stamp = np.zeros(1)

    def applied(self) -> dict:
        """The sensing axis and noise seed this gyro measures with (testbed.campaign.applied_values)."""
        return {"axis": self.axis.tolist(), "seed": self.noise.seed}

    @classmethod
    def batched(cls, stages: list) -> "RateGyros":
        """The gyros of a batch's worlds on (N, ...) arrays (testbed.batch.stage_forms)."""
        return RateGyros(stages)

    def measure(self, t, plant):
        if self.tick % self.every_tick == 0:
            p = self.params
            y = self.noise.add(sensed_rate(self._axis, plant.omega().tolist(), p.bias_rad_s), p.noise_sigma_rad_s)
            if p.quantisation_rad_s:
                y = quantised(y, p.quantisation_rad_s)
            self.y = np.array([y])
            self.stamp = np.array([t])
        self.tick += 1
        return {"y": self.y, "stamp": self.stamp}


def sensed_rate(axis, omega, bias):
    """p . w + bias [rad/s] (Lebedev 1976, eq. 1.1, with a bias), the axis p and the body rate w
    [rad/s] as three components each: floats, or arrays of one value per world (a batch's)."""
    return axis[0] * omega[0] + axis[1] * omega[1] + axis[2] * omega[2] + bias


def quantised(y, step):
    """y [rad/s] rounded to a whole number of output steps `step` > 0 [rad/s]."""
    return step * np.round(y / step)


class RateGyros:
    """The rate gyros of a batch's worlds (`RateGyro.batched`): each world's sample is its own
    gyro's to the bit (the same `sensed_rate`, and its own noise generator drawing the same
    sequence, a block at a time: a block of k draws is k single draws), the same sampling
    period, hold, bias and quantisation. Form contract: testbed.batch.stage_forms.BatchedForm."""

    NOISE_BLOCK = 256  # draws taken from a world's generator at once

    def __init__(self, stages: list):
        self.stages = list(stages)
        params = [stage.params for stage in self.stages]
        self.axis = np.array([stage.axis for stage in self.stages]).T.copy()   # (3, N)
        self.bias = np.array([p.bias_rad_s for p in params], float)
        self.sigma = np.array([p.noise_sigma_rad_s for p in params], float)
        self.step = np.array([p.quantisation_rad_s for p in params], float)
        self.every_tick = np.array([stage.every_tick for stage in self.stages])
        self.tick = self.stages[0].tick
        if any(stage.tick != self.tick for stage in self.stages):
            raise ValueError("the worlds' gyros have sampled differently: batch them from the start")
        self.y = np.array([stage.y for stage in self.stages], float)          # (N, 1)
        self.stamp = np.array([stage.stamp for stage in self.stages], float)  # (N, 1)
        self.noisy, self.coarse = np.flatnonzero(self.sigma), np.flatnonzero(self.step)
        self.draws = np.zeros((len(self.stages), self.NOISE_BLOCK))
        self.drawn = np.full(len(self.stages), self.NOISE_BLOCK)  # the draws used of each world's block

    def keep(self, rows: np.ndarray) -> None:
        self.stages = [self.stages[i] for i in rows]
        self.axis = self.axis[:, rows]
        for name in ("bias", "sigma", "step", "every_tick", "y", "stamp", "draws", "drawn"):
            setattr(self, name, getattr(self, name)[rows])
        self.noisy, self.coarse = np.flatnonzero(self.sigma), np.flatnonzero(self.step)

    def settle(self, row: int) -> None:
        """The gyro's held sample and its tick count back in the world's own stage."""
        stage = self.stages[row]
        stage.tick, stage.y, stage.stamp = self.tick, self.y[row].copy(), self.stamp[row].copy()

    def _noise(self, rows: np.ndarray) -> np.ndarray:
        """The next standard-normal draw of each world at `rows`, from its own generator."""
        drawn = self.drawn[rows]
        if drawn.max() == self.NOISE_BLOCK:
            for row in rows[drawn == self.NOISE_BLOCK].tolist():
                self.draws[row] = self.stages[row].noise.rng.standard_normal(self.NOISE_BLOCK)
            drawn[drawn == self.NOISE_BLOCK] = 0
        self.drawn[rows] = drawn + 1
        return self.draws[rows, drawn]

    def _sampled(self) -> np.ndarray | slice:
        """The rows that take a sample at this tick: all of them (a slice) when every world's gyro
        samples now, as at every tick of the usual batch whose gyros sample at the call rate."""
        due = self.tick % self.every_tick == 0
        return slice(None) if due.all() else np.flatnonzero(due)

    def measure(self, t: float, plants: list) -> dict:
        """y (N, 1) [rad/s] and its time stamp (N, 1) [s], as each world's `RateGyro.measure`."""
        failures = {}
        sampled = self._sampled()
        rows = np.arange(len(self.stages))[sampled]
        if len(rows):
            omega = np.array([plants[row].omega() for row in rows.tolist()]).T
            sigma, step = self.sigma[sampled], self.step[sampled]
            with np.errstate(all="ignore"):   # a blown-up world's rate: its own estimator says so (its replay)
                y = sensed_rate(self.axis[:, sampled], omega, self.bias[sampled])
                noisy = self.noisy if isinstance(sampled, slice) else np.flatnonzero(sigma)
                if len(noisy):   # (a noise-free gyro draws nothing)
                    y[noisy] += sigma[noisy] * self._noise(rows[noisy])
                coarse = self.coarse if isinstance(sampled, slice) else np.flatnonzero(step)
                if len(coarse):
                    y[coarse] = quantised(y[coarse], step[coarse])
            self.y, self.stamp = self.y.copy(), self.stamp.copy()
            self.y[sampled, 0], self.stamp[sampled, 0] = y, t
            failures = self._replay_overflows(t, plants, rows[~np.isfinite(y)])
        self.tick += 1
        if failures:
            raise WorldsFailed(failures, {"y": self.y, "stamp": self.stamp})
        return {"y": self.y, "stamp": self.stamp}

    def _replay_overflows(self, t: float, plants: list, rows: np.ndarray) -> dict:
        """Each world at `rows` (a non-finite sample) measured by its own gyro: the row of the one
        whose arithmetic overflowed fails as its single run does (row -> StageFailed); a rate
        already non-finite gives its sample as it is."""
        failures = {}
        for row in rows.tolist():
            stage = self.stages[row]
            stage.tick = self.tick
            out, failures[row] = replayed(t, "sensor", stage, lambda: stage.measure(t, plants[row]))
            if out is not None:
                self.y[row] = out["y"]
                del failures[row]
        return failures

