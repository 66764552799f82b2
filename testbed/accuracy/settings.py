"""The scenario's `accuracy:` block: the guard's thresholds, each a typed field (docs/theory/accuracy.md)."""

from __future__ import annotations

from dataclasses import dataclass

from testbed.scenario.schema import param


@dataclass(kw_only=True)
class AccuracySettings:
    """Thresholds of the accuracy guard; a scenario relaxes one by setting it, or all with enabled: false.

    step_angle_max_rad: the largest angle the fastest rate of the model may turn in one physics
        step, rate x dt (the bus rate at t = 0 is refused before the run, the largest bus rate
        seen fails the run). RK4 on a rotation at rate w loses (w dt)^5 / 120 of phase a step;
        its stability limit is 2.83 rad, and the stiff gimbal servo was measured to diverge
        near 1 and to track well below 0.7.
    momentum_drift_rel_max: the largest momentum_drift_rel where no external torque acts.
    energy_drift_rel_max: the largest energy_drift_rel where moreover no actuator works.
    tracking_error_rel_max: the largest miss of the plant's actuator servo beyond the command
        jumps it was just handed, relative to the command's amplitude (the plant's
        `tracking_monitor`; docs/theory/accuracy.md, "The servo's tracking").
    A check the scenario sets on momentum_drift_rel or energy_drift_rel replaces the guard's
    default for it.
    """

    enabled: bool = param(True, doc="run the accuracy guard")
    step_angle_max_rad: float = param(0.7, gt=0, doc="largest rate x dt of the model's fastest rate")
    momentum_drift_rel_max: float = param(1e-6, gt=0, doc="largest momentum_drift_rel with no external torque")
    energy_drift_rel_max: float = param(1e-6, gt=0, doc="largest energy_drift_rel where nothing works")
    tracking_error_rel_max: float = param(0.05, gt=0, doc="largest miss of the actuator servo beyond its command jumps, relative to the command")
