"""The monitors read after a run: conservation, step angle, servo tracking (docs/theory/accuracy.md).

Each compares a figure of the run with its threshold in the scenario's `accuracy:` block
(`AccuracySettings`); a figure over its threshold becomes a failed check (`CHECK_NAMES`)
with a one-line reason that names dt. A check the scenario sets on the same metric replaces the
guard's default for it (the scenario chose that bound).
"""

from __future__ import annotations

import math

from testbed.accuracy.step_size import BUS_RATE
from testbed.recording.reductions import MaxNorm

BUS_RATE_PEAK = MaxNorm("truth/omega")
# the names of the checks the guard may fail (a campaign table has a column for each)
CHECK_NAMES = ("accuracy:momentum_drift", "accuracy:energy_drift", "accuracy:tracking", "accuracy:step_angle")


def reductions(scenario) -> list:
    """The running reductions the guard reads (none when it is off)."""
    return [BUS_RATE_PEAK] if scenario.accuracy.enabled else []


def monitored(scenario, plant) -> dict[str, tuple[str, str, float, str]]:
    """metric -> (check name, threshold key, threshold, what it measures) of the metrics the guard bounds."""
    guard = scenario.accuracy
    rows = {"momentum_drift_rel": (CHECK_NAMES[0], "momentum_drift_rel_max", guard.momentum_drift_rel_max,
                                   "total angular momentum drifted"),
            "energy_drift_rel": (CHECK_NAMES[1], "energy_drift_rel_max", guard.energy_drift_rel_max,
                                 "kinetic energy drifted")}
    tracking = getattr(plant, "tracking_metric", None)
    if tracking is not None:
        rows[tracking] = (CHECK_NAMES[2], "tracking_error_rel_max", guard.tracking_error_rel_max,
                          f"the actuator servo's {tracking} is")
    return rows


def guard_checks(scenario, plant, values: dict[str, float], data) -> list[dict]:
    """The failed guard checks of a finished run (rows like testbed.metrics.evaluate_checks's)."""
    guard = scenario.accuracy
    if not guard.enabled:
        return []
    dt = scenario.sim.dt_s
    rows = []
    for name, (check, key, limit, what) in monitored(scenario, plant).items():
        value = values.get(name)
        if value is None or name in scenario.checks or not math.isfinite(value) or value <= limit:
            continue  # not measured here, bounded by the scenario itself, or a NaN its own check reports
        rows.append({"name": check, "value": value, "limit": f"<= {limit:g}", "passed": False,
                     "reason": f"{what} {value:.3g} (accuracy.{key} {limit:g}) at dt {dt:g} s: "
                               f"lower sim.dt_s, or relax accuracy.{key}"})
    try:
        peak = data.reduced(BUS_RATE_PEAK)
    except (KeyError, ValueError):  # no bus rate recorded (not a free body)
        return rows
    angle = peak * dt
    if math.isfinite(angle) and angle > guard.step_angle_max_rad:
        rows.append({"name": CHECK_NAMES[3], "value": angle, "limit": f"<= {guard.step_angle_max_rad:g}",
                     "passed": False,
                     "reason": f"the {BUS_RATE} reached {peak:.3g} rad/s, {angle:.3g} rad a step at dt {dt:g} s "
                               f"(accuracy.step_angle_max_rad {guard.step_angle_max_rad:g}): lower sim.dt_s"})
    return rows
