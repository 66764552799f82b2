"""The monitors read after a run: conservation, step angle, servo tracking (docs/theory/accuracy.md).

Each compares a figure of the run with its threshold in the scenario's `accuracy:` block
(`AccuracySettings`); a figure over its threshold becomes a failed check (`CHECK_NAMES`)
with a one-line reason that names dt. Which monitors apply is decided from the model and the
pipeline the run was built with (`Monitors`): a conservation monitor only where the physics
conserves its quantity. A check the scenario sets on the same metric replaces the guard's
default for it (the scenario chose that bound).
"""

from __future__ import annotations

import math

from testbed.accuracy.step_size import BUS_RATE
from testbed.recording.reductions import MaxNorm

BUS_RATE_PEAK = MaxNorm("truth/omega")
# the names of the checks the guard may fail (a campaign table has a column for each)
CHECK_NAMES = ("accuracy:momentum_drift", "accuracy:energy_drift", "accuracy:tracking", "accuracy:step_angle")


class Monitors:
    """The guard's monitors of one run, chosen once the plant and pipeline are built.

    momentum: the run's momentum_drift_rel, energy: energy_drift_rel, where the run's physics
    conserved them (`conservation.kept_by(plant)`, testbed.run_core.conservation); tracking: the
    plant's `tracking_monitor` (a running reduction and its figure), when it has one for what the
    allocator commands (`command_key`); the step angle from the largest recorded bus rate times
    the physics step `dt` [s]."""

    def __init__(self, scenario, plant, command_key: str | None, conservation, dt: float):
        self.enabled = scenario.accuracy.enabled
        self.plant, self.conservation, self.dt = plant, conservation, dt
        self.tracking = plant.tracking_monitor(command_key) if self.enabled else None

    def conserved(self, guard) -> dict[str, tuple]:
        """metric -> (check, threshold key, threshold, what it measures) of the conserved
        quantities, read at the end of the run (a body torque given at any step breaks them)."""
        kept = self.conservation.kept_by(self.plant)
        rows = {}
        if kept.momentum:
            rows["momentum_drift_rel"] = (CHECK_NAMES[0], "momentum_drift_rel_max", guard.momentum_drift_rel_max,
                                          "total angular momentum drifted")
        if kept.energy:
            rows["energy_drift_rel"] = (CHECK_NAMES[1], "energy_drift_rel_max", guard.energy_drift_rel_max,
                                        "kinetic energy drifted")
        return rows

    def reductions(self) -> list:
        """The running reductions the guard reads (none when it is off)."""
        if not self.enabled:
            return []
        return [BUS_RATE_PEAK] + ([self.tracking[0]] if self.tracking else [])

    def figures(self, scenario, values: dict[str, float], data) -> dict[str, tuple]:
        """check name -> (figure, threshold, threshold key, what it measures) of each monitor that
        applies to the finished run (NaN: not measured); a conserved metric the scenario bounds
        by its own check is left to that check."""
        guard = scenario.accuracy
        if not self.enabled:
            return {}
        found = {check: (values.get(name, float("nan")), limit, key, what)
                 for name, (check, key, limit, what) in self.conserved(guard).items() if name not in scenario.checks}
        if self.tracking is not None:
            reduction, figure, what = self.tracking
            found[CHECK_NAMES[2]] = (_reduced(data, reduction, figure), guard.tracking_error_rel_max,
                                     "tracking_error_rel_max", what)
        peak = _reduced(data, BUS_RATE_PEAK, float)
        found[CHECK_NAMES[3]] = (peak * self.dt, guard.step_angle_max_rad, "step_angle_max_rad",
                                 f"the {BUS_RATE} reached {peak:.3g} rad/s, in rad a step,")
        return found

    def checks(self, scenario, values: dict[str, float], data) -> list[dict]:
        """The failed guard checks of a finished run (rows like testbed.metrics.evaluate_checks's):
        a figure over its threshold; a NaN figure is not judged (its metric's own check reports it)."""
        return [{"name": check, "value": value, "limit": f"<= {limit:g}", "passed": False,
                 "reason": f"{what} {value:.3g} (accuracy.{key} {limit:g}) at dt {self.dt:g} s: "
                           f"lower sim.dt_s, or relax accuracy.{key}"}
                for check, (value, limit, key, what) in self.figures(scenario, values, data).items()
                if math.isfinite(value) and value > limit]


def _reduced(data, reduction, figure) -> float:
    """figure(the reduction's value), NaN when the run recorded none of it."""
    try:
        return figure(data.reduced(reduction))
    except (KeyError, ValueError):
        return float("nan")
