"""The Lebedev observer and law of a batch's worlds on (N, ...) arrays (testbed.batch.stage_forms).

Each world's row is computed by the same functions as its own stage, on one value per world
instead of one float: `startup_rates` and `fixed_gain_rates` (eq. 3.1 and 4.6) through the same
RK4 (`rk4_steps`), `gyrostat_jacobian` and `is_hurwitz` for the validity test, `lebedev_torque`
(eq. 4.7). Elementwise arithmetic in one order is the same float for float, so a row is its
single run's to the bit wherever the single run's numbers are those of `eigvals` and a matrix
product with the paper's A (whose zeros make any order of summation exact). A row that turns
non-finite or leaves the observer's validity is replayed by its own stage from the state before
the step, so it fails with its single run's status and error while the others go on.
"""

from __future__ import annotations

import numpy as np

from testbed.batch.stage_forms import WorldsFailed, replayed, rows_of
from testbed.lebedev.observer import fixed_gain_rates, lebedev_torque, output_error, startup_rates
from testbed.lebedev.validity import GROWTH_LIMIT, error_matrix, is_hurwitz
from testbed.math.rk4 import rk4_steps


def _columns(values) -> np.ndarray:
    """Per-world vectors (N, ...) as (..., N): a component's values across the worlds contiguous."""
    return np.moveaxis(np.array(values, float), 0, -1).copy()


def _same(values: list, what: str):
    """The one value every world has for `what`; refused (ValueError) when they differ."""
    if any(value != values[0] for value in values[1:]):
        raise ValueError(f"the worlds' lebedev estimators differ in {what}: batch them apart")
    return values[0]


class LebedevEstimates:
    """The fixed-gain observers (eq. 3.1 then 4.6, with the validity test of
    testbed.lebedev.validity) of a batch's worlds: `LebedevEstimator.batched`. State per world,
    vectors as (3, N): the estimate z, the last sample, ln of the error growth owed and since
    when; the worlds share the start-up time, the sample instants and the RK4 substeps."""

    def __init__(self, stages: list):
        self.stages = list(stages)
        observers = [stage.observer for stage in self.stages]
        self.startup = _same([stage.startup for stage in self.stages], "startup_s")
        self.torque_key = _same([stage.torque_key for stage in self.stages], "the delivered-torque key")
        self.t_prev = _same([stage._t_prev for stage in self.stages], "the time of their last sample")
        self.y_prev = np.array([stage._y_prev for stage in self.stages], float)
        self.z = _columns([obs.z for obs in observers])
        self.spin = np.array([obs.spin_rate for obs in observers])
        self.target = np.zeros((3, len(observers)))
        self.target[2] = self.spin                    # (0, 0, Omega): w_hat = z + target (eq. 4.1)
        self.c, self.a = _columns([obs.C for obs in observers]), _columns([obs.a for obs in observers])
        self.A = _columns([obs.A for obs in observers])                          # (3, 3, N)
        self.l, self.l_closed = _columns([obs.l for obs in observers]), _columns([obs.l_closed for obs in observers])
        self.inertia = _columns([stage.inertia for stage in self.stages])
        self.linear_hold = np.array([stage.linear_hold for stage in self.stages])
        growths = [stage.growth for stage in self.stages]
        self.moments = np.array([g.moments for g in growths])                    # (N, 3): the validity test's
        self.momentum = np.array([g.momentum for g in growths])                  # (N, 3)
        self.gain_times_c = np.array([g.gain_times_c for g in growths])          # (N, 3, 3)
        self.log_growth = np.array([g.log_growth for g in growths])
        self.since = np.array([np.nan if g.since is None else g.since for g in growths])
        self.replayed: set = set()   # the rows that failed this tick, their stages in their failed state

    @classmethod
    def of(cls, stages: list):
        """The form of these estimators, or None (per world) when one follows the measured
        momentum (its information filter and held command are its own stage's) or their RK4
        substeps differ."""
        if any(stage.momentum_key is not None for stage in stages):
            return None
        if len({stage.observer.max_substep for stage in stages}) > 1:
            return None
        return cls(stages)

    def keep(self, rows: np.ndarray) -> None:
        self.stages = [self.stages[i] for i in rows]
        self.replayed = set()
        for name in ("y_prev", "spin", "linear_hold", "moments", "momentum", "gain_times_c", "log_growth", "since"):
            setattr(self, name, getattr(self, name)[rows])
        for name in ("z", "target", "c", "a", "A", "l", "l_closed", "inertia"):
            setattr(self, name, getattr(self, name)[..., rows])

    def settle(self, row: int) -> None:
        """The row's observer state back in its world's own stage (a row that failed left its
        stage as its single run's failure leaves it: `_replay`)."""
        if row not in self.replayed:
            self._put(row, self.z[:, row], self.log_growth[row], self.since[row])

    def _put(self, row: int, z, log_growth, since) -> None:
        stage = self.stages[row]
        stage._t_prev, stage._y_prev = self.t_prev, float(self.y_prev[row])
        stage.observer.z = np.array(z, float)
        stage.growth.log_growth = float(log_growth)
        stage.growth.since = None if np.isnan(since) else float(since)

    def _derivative(self, closed: bool, y_dev, slope, u):
        """f(s, z) of the observer ODE over an interval, z as (3, N): eq. 4.6 (`fixed_gain_rates`)
        once the loop is closed, else eq. 3.1 (`startup_rates`)."""
        A, c = self.A, self.c

        def rates(s, z):
            linear = np.einsum("ijn,jn->in", A, z)
            y = y_dev if slope is None else y_dev + s * slope
            if closed:
                return np.array(fixed_gain_rates(linear, self.l_closed, self.a, c, z, y, u))
            return np.array(startup_rates(linear, (0.0, 0.0, 0.0), self.l, c, z, y))
        return rates

    def _step(self, y, h: float, command: dict) -> np.ndarray:
        """z after the interval of length h [s] that ends at the samples y (each world's
        `LebedevEstimator._step`: the sample at its start held or interpolated to y)."""
        y_dev = self.y_prev - self.c[2] * self.spin
        slope = None
        if self.linear_hold.any():
            slope = np.where(self.linear_hold, y - self.y_prev, 0.0)
        closed = not self.t_prev < self.startup
        u = None
        if closed:
            torque = command.get(self.torque_key)
            u = np.zeros_like(self.z) if torque is None else np.asarray(torque, float).T / self.inertia
        n = self.stages[0].observer.substeps(h)   # the worlds' max_substep is one (`of`)
        return rk4_steps(self._derivative(closed, y_dev, slope, u), self.z, h, n)

    def _growth(self, t: float, h: float, z: np.ndarray) -> tuple:
        """(ln growth, since, finite) after the interval of length h [s] ending at t [s] with the
        estimates z, each world's `ErrorGrowth.advance` (without its raise: a row at GROWTH_LIMIT
        is replayed); rows whose test matrix is not `finite` keep the old values (they are replayed)."""
        matrix = error_matrix(self.moments, (z + self.target).T, self.momentum, self.gain_times_c)
        finite = np.isfinite(matrix.reshape(-1, 9).sum(axis=1))   # (a sum that overflows: replayed too)
        log_growth, since = self.log_growth.copy(), self.since.copy()
        asked = np.flatnonzero(finite & ((log_growth != 0.0) | ~is_hurwitz(matrix)))
        if len(asked):
            sigma = np.linalg.eigvals(matrix[asked]).real.max(axis=-1)
            owed = log_growth[asked]
            since[asked[(owed == 0.0) & (sigma > 0.0)]] = t - h
            log_growth[asked] = np.maximum(0.0, owed + sigma * h)
        return log_growth, since, finite

    def estimate(self, t: float, measurement: dict, command: dict) -> dict:
        """Each world's `LebedevEstimator.estimate` at t [s]: z, omega_estimate, closed_loop,
        innovation and, once closed, omega, as (N, ...)."""
        y = np.asarray(measurement["y"], float)[:, 0]
        failures = {}
        if self.t_prev is not None:
            h = t - self.t_prev
            with np.errstate(all="ignore"):
                z = self._step(y, h, command)
                bad = ~np.isfinite(z).all(axis=0)
                log_growth, since = self.log_growth, self.since
                if not self.t_prev < self.startup:
                    log_growth, since, finite = self._growth(t, h, z)
                    bad |= ~finite | (log_growth >= GROWTH_LIMIT)
            if bad.any():
                failures = self._replay(t, np.flatnonzero(bad), measurement, command, z, log_growth, since)
            self.z, self.log_growth, self.since = z, log_growth, since
        self.t_prev, self.y_prev = t, y
        with np.errstate(all="ignore"):
            innovation = output_error(self.c, self.z, y - self.c[2] * self.spin)
            omega = (self.z + self.target).T
        count = len(self.stages)
        closed = t >= self.startup
        out = {"z": self.z.T.copy(), "omega_estimate": omega, "closed_loop": np.full((count, 1), float(closed)),
               "innovation": innovation[:, None]}
        if closed:
            out["omega"] = omega.copy()
        if failures:
            raise WorldsFailed(failures, out)
        return out

    def _replay(self, t: float, rows: np.ndarray, measurement: dict, command: dict, z, log_growth, since) -> dict:
        """Each world at `rows` redoes this step with its own stage from its state before it: the
        ones that fail, row -> StageFailed, as their single runs; the others' rows (z, log_growth,
        since, updated in place) become what their stage computed."""
        measured, commanded = rows_of(measurement, len(self.stages)), rows_of(command, len(self.stages))
        failures = {}
        for row in rows.tolist():
            self._put(row, self.z[:, row], self.log_growth[row], self.since[row])
            stage = self.stages[row]
            out, failure = replayed(t, "estimator", stage, lambda: stage.estimate(t, measured[row], commanded[row]))
            if failure is not None:
                failures[row] = failure
                self.replayed.add(row)
            else:
                z[:, row], log_growth[row] = stage.observer.z, stage.growth.log_growth
                since[row] = np.nan if stage.growth.since is None else stage.growth.since
        return failures


class LebedevTorques:
    """The law M_i = I_i k_i z_i (eq. 4.7) of a batch's worlds: `LebedevLaw.batched`; zero torque
    in the rows whose estimator reports the loop open."""

    def __init__(self, stages: list):
        self.stages = list(stages)
        self.inertia = np.array([stage.inertia for stage in self.stages])
        self.k = np.array([stage.k for stage in self.stages])
        self.target = np.array([stage.target for stage in self.stages])

    def keep(self, rows: np.ndarray) -> None:
        self.stages = [self.stages[i] for i in rows]
        self.inertia, self.k, self.target = self.inertia[rows], self.k[rows], self.target[rows]

    def settle(self, row: int) -> None:
        """Nothing to write back: the law keeps no state."""

    def torque(self, t: float, estimate: dict) -> dict:
        """Each world's `LebedevLaw.torque` at t [s]: {"torque": (N, 3) [N m]}."""
        if "omega" not in estimate:
            return {"torque": np.zeros_like(self.inertia)}
        with np.errstate(all="ignore"):
            torque = lebedev_torque(self.inertia, self.k, np.asarray(estimate["omega"], float) - self.target)
        if "closed_loop" in estimate:
            open_ = np.asarray(estimate["closed_loop"])[:, 0] == 0.0
            if open_.any():
                torque[open_] = 0.0
        failures = {}
        finite = np.isfinite(torque.sum(axis=1))   # (a sum that overflows: replayed too)
        for row in ([] if finite.all() else np.flatnonzero(~finite).tolist()):
            stage, given = self.stages[row], {key: value[row] for key, value in estimate.items()}
            out, failures[row] = replayed(t, "law", stage, lambda: stage.torque(t, given))
            if out is not None:
                torque[row] = out["torque"]
                del failures[row]
        if failures:
            raise WorldsFailed(failures, {"torque": torque})
        return {"torque": torque}
