"""The steering allocator (stage.py) on many worlds at once: the batched form of its stage
(testbed.batch.stage_forms), a row per world, for the laws with a form on rows (ROW_LAWS).

Each world keeps its own cluster geometry (a campaign's dispersions may differ), rate limit and
statistics; the form holds them as (N, ...) arrays and writes the statistics back into each
world's stage (`settle`). Row i is what world i's `SteeringAllocator.allocate` gives, to
round-off: the gimbal angles' sines and cosines and the momentum sums are numpy's instead of
the single stage's float loops (an ulp or so), the laws' arithmetic is the same (min-max to the
bit, the SR family to an ulp of its solves). Gimbal limits (gimbal_limits.py) bound each row's
rates from its own set-point and last command; a world without them has the box +-beta'max, which
bounds its rates as the symmetric limit does, to the bit. Fault isolation keeps a per-unit state
machine in the single stage: worlds with it run per world (`batched_form` gives None).
"""

from __future__ import annotations

import numpy as np

from testbed.batch.stage_forms import WorldsFailed, rows_of
from testbed.errors import described
from testbed.math.cross import cross3
from testbed.run_core.stage_contract import Declared, MethodFailed, StageFailed
from testbed.steering.gimbal_limits import ACCELERATION_ROUNDING, GimbalLimits
from testbed.steering.minimax_exact import minimax_steering_rows
from testbed.steering.off_diagonal_sr import osr_steering_rows
from testbed.steering.pseudo_inverse import pinv_steering_rows
from testbed.steering.result import SteeringRows
from testbed.steering.singular_direction_avoidance import sda_steering_rows
from testbed.steering.singularity_type import NOT_SINGULAR
from testbed.steering.sr_inverse import gsr_steering_rows, sr_steering_rows

# law name -> its form on rows: law_rows(J (N, 3, n), h (N,), hdot (N, 3), beta_rate_max (N,), **options)
# minimax_lp (an LP per world), minimax_avoid and pga (state and the LP) run per world
ROW_LAWS = {"pinv": pinv_steering_rows, "sr": sr_steering_rows, "gsr": gsr_steering_rows,
            "osr": osr_steering_rows, "sda": sda_steering_rows, "minimax": minimax_steering_rows}
# the counts and extremes `SteeringAllocator._count` keeps
FLOAT_STATISTICS = ("peak_gimbal_rate", "min_singularity", "min_scale", "peak_gimbal_acceleration", "min_angle_margin")
COUNT_STATISTICS = ("rate_limit_violations", "steps", "acceleration_violations", "angle_limit_violations")


def batched_form(stages: list):
    """The steering stages' form on their worlds (`BatchedSteering`), or None (run them per world)
    for one world alone (numpy's per-call cost on rows of one is more than the single stage's tick),
    when a world has fault isolation, the worlds' options or unit counts differ, or the law has no
    form on rows."""
    first = stages[0]
    law_rows = ROW_LAWS.get(first.law_name)
    gimbals = len(first.geometry.gimbal_axes)
    if len(stages) < 2 or law_rows is None or (first.law_name == "minimax" and gimbals != 4):
        return None
    for stage in stages:
        if (stage.isolation is not None or stage.options != first.options
                or len(stage.geometry.gimbal_axes) != gimbals):
            return None
    return BatchedSteering(stages, law_rows)


class BatchedSteering:
    """`SteeringAllocator.allocate` of N worlds on (N, ...) arrays (module doc); `stages` the
    worlds' own stages (one law, no fault isolation), `law_rows` the law's form."""

    def __init__(self, stages: list, law_rows):
        self.stages = list(stages)
        first = stages[0]
        self.law_rows = law_rows
        keywords = first.law.__kwdefaults__ | first.options
        self.takes_time = "t" in keywords
        self.options = {name: value for name, value in keywords.items() if name not in ("t", "rate_bounds")}
        geometries = [stage.geometry for stage in stages]
        self.spin_zero = np.array([g.spin_axes_zero for g in geometries])  # (N, n, 3)
        self.turn = np.array([g.turn_axes for g in geometries])
        self.column_scale = np.array([np.ones(len(g.gimbal_axes)) if g.relative_momentum is None
                                      else g.relative_momentum for g in geometries])
        self.spin_inertia = np.array([g.spin_inertia for g in geometries])
        self.turning_inertia = np.array([g.gimbal_axis_inertia for g in geometries])
        self.gimbal_axes = np.array([g.gimbal_axes for g in geometries])
        self.h = np.array([g.h for g in geometries])
        self.rate_max = np.array([stage.rate_max for stage in stages])
        self.period = np.array([stage.period for stage in stages])
        self.adds_gyroscopic = np.array([stage.adds_gyroscopic for stage in stages])
        self.classify_below = np.array([stage.classify_below if stage.classifies else -np.inf for stage in stages])
        self.previous = np.array([np.asarray(stage.previous, dtype=float) for stage in stages])
        # every world's gimbal limits as one GimbalLimits of rows (none: +-inf and no acceleration
        # limit), and the commanded angles (NaN until a world's first tick: its measured ones)
        self.limits = None
        if any(stage.limits is not None for stage in stages):
            free = np.full(len(first.geometry.gimbal_axes), np.inf)
            given = [stage.limits or GimbalLimits(-free, free, np.inf, stage.period) for stage in stages]
            self.limits = GimbalLimits(np.array([g.angle_min for g in given]), np.array([g.angle_max for g in given]),
                                       np.array([[g.acceleration_max] for g in given]),
                                       np.array([[g.period] for g in given]))
        self.setpoint = np.array([np.full(len(first.geometry.gimbal_axes), np.nan) if stage.setpoint is None
                                  else stage.setpoint for stage in stages])
        self.statistics = {name: np.array([stage.statistics[name] for stage in stages], dtype=float)
                           for name in FLOAT_STATISTICS}
        self.statistics |= {name: np.array([stage.statistics[name] for stage in stages], dtype=int)
                            for name in COUNT_STATISTICS}

    def keep(self, rows: np.ndarray) -> None:
        """Only the worlds at `rows` go on."""
        self.stages = [self.stages[i] for i in rows]
        for name in ("spin_zero", "turn", "column_scale", "spin_inertia", "turning_inertia", "gimbal_axes", "h",
                     "rate_max", "period", "adds_gyroscopic", "classify_below", "previous", "setpoint"):
            setattr(self, name, getattr(self, name)[rows])
        if self.limits is not None:
            self.limits = GimbalLimits(self.limits.angle_min[rows], self.limits.angle_max[rows],
                                       self.limits.acceleration_max[rows], self.limits.period[rows])
        self.statistics = {name: values[rows] for name, values in self.statistics.items()}

    def settle(self, row: int) -> None:
        """World `row`'s statistics and last command back into its own stage."""
        stage = self.stages[row]
        stage.statistics.update({name: float(self.statistics[name][row]) for name in FLOAT_STATISTICS})
        stage.statistics.update({name: int(self.statistics[name][row]) for name in COUNT_STATISTICS})
        stage.previous = self.previous[row].copy()
        if stage.limits is not None and not np.isnan(self.setpoint[row, 0]):
            stage.setpoint = self.setpoint[row].copy()

    def allocate(self, t: float, demand: dict, estimate: dict, actuators: dict) -> dict:
        """Each world's `SteeringAllocator.allocate` at t [s], a row each; a world whose demand,
        estimate or read-outs are not finite fails as its own stage does (`WorldsFailed`)."""
        with np.errstate(all="ignore"):
            beta = np.asarray(actuators["gimbal_angle"], dtype=float)
            count = len(beta)
            torque = np.asarray(demand["torque"], float) if "torque" in demand else np.zeros((count, 3))
            omega = np.asarray(estimate["omega"], float) if "omega" in estimate else np.zeros((count, 3))
            # ClusterGeometry.turned_axes, momentum and unit_jacobian of each world
            cos, sin = np.cos(beta)[:, :, None], np.sin(beta)[:, :, None]
            spin = cos * self.spin_zero + sin * self.turn
            jacobian = np.swapaxes(cos * self.turn - sin * self.spin_zero, 1, 2) * self.column_scale[:, None, :]
            spun = self.spin_inertia * np.asarray(actuators["rotor_rate"], dtype=float)
            momentum = (spun[:, None, :] @ spin)[:, 0, :]
            gyroscopic = np.where(self.adds_gyroscopic[:, None], cross3(omega, momentum), 0.0)
            hdot = -(torque + gyroscopic)
            # the single law's check (validation.checked_problem): a sum is finite only if every term is
            finite = np.isfinite(hdot.sum(axis=1) + jacobian.sum(axis=(1, 2)))
            everyone = bool(finite.all())
            live = slice(None) if everyone else np.flatnonzero(finite)
            keywords = self.options | {"t": t} if self.takes_time else self.options
            if self.limits is not None:
                self.setpoint = np.where(np.isnan(self.setpoint), beta, self.setpoint)
                keywords = keywords | {"rate_bounds": self.limits.rate_bounds(self.setpoint, self.previous,
                                                                             self.rate_max[:, None])}
            if everyone:
                result = self.law_rows(jacobian, self.h, hdot, self.rate_max, **keywords)
            else:  # the others' rows; the failed worlds' stay at rest (their own stages name the failure)
                result = SteeringRows(np.zeros((count, jacobian.shape[2])), np.zeros((count, 3)), np.ones(count),
                                      np.zeros(count), np.zeros(count, int), np.zeros(count, int))
                if len(live):
                    if "rate_bounds" in keywords:
                        keywords["rate_bounds"] = [bound[live] for bound in keywords["rate_bounds"]]
                    some = self.law_rows(jacobian[live], self.h[live], hdot[live], self.rate_max[live], **keywords)
                    for name in SteeringRows.__slots__:
                        getattr(result, name)[live] = getattr(some, name)
            self._count(live, result, everyone, beta)
            held = momentum
            if "gimbal_rate" in actuators:  # ClusterGeometry.turning_momentum
                turning = self.turning_inertia * np.asarray(actuators["gimbal_rate"], dtype=float)
                held = momentum + (turning[:, None, :] @ self.gimbal_axes)[:, 0, :]
            measure = result.singularity_measure
            outputs = {"gimbal_rates": result.beta_rate, "torque_delivered": -result.hdot_delivered - gyroscopic,
                       "momentum": momentum, "held_momentum": held, "scale": result.scale[:, None],
                       "singularity": measure[:, None], "rank": result.rank[:, None].astype(float),
                       "status": result.status[:, None].astype(float),
                       "singularity_type": np.full((count, 1), float(NOT_SINGULAR)),
                       "singular_direction": np.zeros((count, 3))}
            for row in np.flatnonzero(finite & (measure < self.classify_below)).tolist():
                outputs["singularity_type"][row], outputs["singular_direction"][row] = self.stages[row]._classified(
                    measure[row], jacobian[row], beta[row], momentum[row])
        if not everyone:
            raise WorldsFailed(self._failures(t, np.flatnonzero(~finite), demand, estimate, actuators), outputs)
        return outputs

    def _count(self, live, result, everyone: bool, beta) -> None:
        """`SteeringAllocator._count` of the rows `live` (all when `everyone`), `beta` the measured
        angles [rad]; the commanded angles move on with the command (the servos' set-points)."""
        s = self.statistics
        if not everyone:
            result = SteeringRows(*(getattr(result, name)[live] for name in SteeringRows.__slots__))
        rates = np.abs(result.beta_rate)
        s["peak_gimbal_rate"][live] = np.maximum(s["peak_gimbal_rate"][live], rates.max(axis=1))
        s["rate_limit_violations"][live] += np.count_nonzero(rates > self.rate_max[live][:, None], axis=1)
        s["min_singularity"][live] = np.minimum(s["min_singularity"][live], result.singularity_measure)
        s["min_scale"][live] = np.minimum(s["min_scale"][live], result.scale)
        change = np.abs(result.beta_rate - self.previous[live]).max(axis=1) / self.period[live]
        s["peak_gimbal_acceleration"][live] = np.maximum(s["peak_gimbal_acceleration"][live], change)
        if self.limits is not None:
            limits, period = self.limits, self.period[live][:, None]
            step = limits.rate_step[live] * (1.0 + ACCELERATION_ROUNDING)
            s["acceleration_violations"][live] += np.count_nonzero(
                np.abs(result.beta_rate - self.previous[live]) > step, axis=1)
            commanded = self.setpoint[live] + period * result.beta_rate
            low, high = limits.angle_min[live], limits.angle_max[live]
            s["angle_limit_violations"][live] += np.count_nonzero((commanded < low) | (commanded > high), axis=1)
            margin = np.minimum(beta[live] - low, high - beta[live]).min(axis=1)
            s["min_angle_margin"][live] = np.minimum(s["min_angle_margin"][live], margin)
            self.setpoint[live] = commanded
        s["steps"][live] += 1
        self.previous[live] = result.beta_rate

    def _failures(self, t: float, rows, demand, estimate, actuators) -> dict:
        """row -> the StageFailed its own stage raises on its row's inputs (as a single run's tick
        names it: testbed.run_core.tick.Pipeline._raise_failure)."""
        count = len(self.stages)
        demands, estimates, read = rows_of(demand, count), rows_of(estimate, count), rows_of(actuators, count)
        failures = {}
        for row in rows.tolist():
            stage = self.stages[row]
            name = Declared.of(stage).type_name or type(stage).__name__
            try:
                stage.allocate(t, demands[row], estimates[row], read[row])
                reason, method = "its inputs are not finite", False
            except MethodFailed as exc:
                reason, method = exc.reason, True
            except Exception as exc:  # noqa: BLE001  (what the single stage raises, named as its run names it)
                reason, method = described(exc), False
            failures[row] = StageFailed(t, "allocator", name, reason, method=method)
        return failures
