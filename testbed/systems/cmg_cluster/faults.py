"""Hardware faults of the CMG units, injected into the MuJoCo plant (the truth) at set times.

`model.faults` is a list of timed events, one per unit at most (docs/theory/faults.md):

    stuck           the gimbal's drive jams: it holds the gimbal at its angle whatever it is
                    commanded (the servo is fed a zero rate). Not a MuJoCo joint equality:
                    that soft constraint's stiff mode, under RK4 at dt = 0.01 s, lets the
                    total momentum drift by 5e-7 of the stored momentum on
                    reorient_gimbal_stuck, the servo by 1e-9
    motor_off       the gimbal's drive gives no torque: the gimbal turns freely under the
                    gyroscopic and coupling torques
    rate_limit      the gimbal follows commands up to rate_limit_deg_s only (the servo's
                    command is clipped to it)
    spin_down       the rotor's motor stops: its speed loop holds Omega = 0 with the gain
                    Js / time_constant_s, so Omega decays as exp(-t / tau)
    sensor_bias     the gimbal-rate tachometer reads bias_deg_s more than the truth
    sensor_dropout  the gimbal-rate tachometer reads 0

Every torque a fault changes acts between a unit and the bus, so the total angular momentum is
conserved through a fault. Nothing tells the controller: it sees the encoders and tachometers
(CmgPlant.actuator_state), the sensor faults included, and must detect the fault itself.
A fault starts at the first control tick at or after `at_s` (the plant's commands and its
hardware change at ticks); the trace records each unit's active fault as `truth/fault`
(FAULT_CODES, 0: none).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from testbed.errors import InputError
from testbed.scenario.schema import join, param

FaultKind = Literal["stuck", "motor_off", "rate_limit", "spin_down", "sensor_bias", "sensor_dropout"]
FAULT_CODES = {"stuck": 1, "motor_off": 2, "rate_limit": 3, "spin_down": 4, "sensor_bias": 5, "sensor_dropout": 6}
# the one extra parameter each kind takes (None: none)
KIND_PARAMETER = {"rate_limit": "rate_limit_deg_s", "spin_down": "time_constant_s", "sensor_bias": "bias_deg_s"}
TICK_SLACK = 1e-9  # [s] a fault at a tick's time starts at that tick despite the clock's rounding


@dataclass(kw_only=True)
class FaultEvent:
    """One fault of one CMG unit (module doc)."""

    at_s: float = param(ge=0, doc="time the fault starts (at the first control tick from then)")
    unit: int = param(ge=1, doc="CMG unit that fails, 1 ... 4")
    kind: FaultKind = param(doc="stuck, motor_off, rate_limit, spin_down, sensor_bias or sensor_dropout")
    rate_limit_deg_s: float | None = param(None, gt=0, doc="rate_limit: the lower gimbal-rate limit")
    time_constant_s: float | None = param(None, gt=0, doc="spin_down: tau of the rotor's decay")
    bias_deg_s: float | None = param(None, ge=-1e4, le=1e4, doc="sensor_bias: the tachometer's bias jump")

    def validate(self, path: str) -> None:
        wanted = KIND_PARAMETER.get(self.kind)
        for name in KIND_PARAMETER.values():
            given = getattr(self, name) is not None
            if name == wanted and not given:
                raise InputError(join(path, name), f"a {self.kind} fault needs it")
            if name != wanted and given:
                raise InputError(join(path, name), f"not a parameter of a {self.kind} fault")


def check_faults(faults: list[FaultEvent], units: int, path: str = "model.faults") -> None:
    """Refuse a fault on a unit the cluster does not have and two faults on one unit (a fault
    lasts to the end of the run, so two on one unit would act at once)."""
    first = {}
    for i, fault in enumerate(faults):
        where = f"{path}[{i}]"
        if fault.unit > units:
            raise InputError(f"{where}.unit", f"unit {fault.unit} does not exist: the cluster has units 1 ... {units}")
        if fault.unit in first:
            raise InputError(f"{where}.unit", f"unit {fault.unit} already fails by {path}[{first[fault.unit]}]: "
                             "one fault per unit (two would act at once)")
        first[fault.unit] = i


def check_fault_times(faults: list[FaultEvent], end_time: float, shortest_tau: float, dt: float,
                      path: str = "model.faults") -> None:
    """Refuse a fault that would start after the run's last control tick [s], and a spin-down whose
    time constant is below `shortest_tau` [s], too fast for RK4 at step dt (the rotor loop's bound)."""
    for i, fault in enumerate(faults):
        if fault.at_s > end_time + TICK_SLACK:
            raise InputError(f"{path}[{i}].at_s", f"{fault.at_s:g} s is past the run's last control tick at {end_time:g} s")
        if fault.time_constant_s is not None and fault.time_constant_s < shortest_tau:
            raise InputError(f"{path}[{i}].time_constant_s", f"{fault.time_constant_s:g} s is too short for "
                             f"timestep {dt:g} s under RK4 (at least {shortest_tau:g} s)")


class FaultInjector:
    """Starts the scenario's faults on the plant as its clock passes their times."""

    def __init__(self, plant, faults: list[FaultEvent]):
        self.plant = plant
        self.planned = list(faults)
        self.pending = sorted(faults, key=lambda f: f.at_s)
        units = len(plant.bus.gimbal_qpos_adr)
        self.codes = np.zeros(units)            # truth/fault
        self.rate_bias = np.zeros(units)        # what the tachometers add [rad/s]
        self.rate_dead = np.zeros(units, bool)  # tachometers that read 0

    @property
    def sensors_faulty(self) -> bool:
        """Some tachometer reads other than the truth."""
        return bool(np.any(self.rate_bias) or np.any(self.rate_dead))

    def update(self, t: float) -> None:
        """Start every fault due by time t [s]."""
        while self.pending and self.pending[0].at_s <= t + TICK_SLACK:
            fault = self.pending.pop(0)
            self._start(fault)
            self.codes[fault.unit - 1] = FAULT_CODES[fault.kind]

    def tachometer(self, rates: np.ndarray) -> np.ndarray:
        """What the gimbal-rate tachometers report for the true rates [rad/s]."""
        return np.where(self.rate_dead, 0.0, rates + self.rate_bias)

    def _start(self, fault: FaultEvent) -> None:
        plant, i = self.plant, fault.unit - 1
        model, data, bus = plant.model, plant.data, plant.bus
        if fault.kind == "stuck":
            plant.servo.jam(i)
        elif fault.kind == "motor_off":
            self._cut_drive(i)
        elif fault.kind == "rate_limit":
            limit = np.radians(fault.rate_limit_deg_s)
            servo = bus.gimbal_actuator_ids[i]
            low, high = model.actuator_ctrlrange[servo] if model.actuator_ctrllimited[servo] else (-np.inf, np.inf)
            model.actuator_ctrllimited[servo] = 1
            model.actuator_ctrlrange[servo] = [max(low, -limit), min(high, limit)]
            plant.servo.limit_rate(i, limit)
        elif fault.kind == "spin_down":
            rotor = bus.rotor_actuator_ids[i]
            gain = plant.geometry.spin_inertia[i] / fault.time_constant_s  # velocity loop: kv (ctrl - Omega)
            model.actuator_gainprm[rotor, 0] = gain
            model.actuator_biasprm[rotor, 2] = -gain
            model.actuator_ctrllimited[rotor] = 0  # a speed range must not hold the stopped motor's 0
            data.ctrl[rotor] = 0.0
        elif fault.kind == "sensor_bias":
            self.rate_bias[i] = np.radians(fault.bias_deg_s)
        elif fault.kind == "sensor_dropout":
            self.rate_dead[i] = True

    def _cut_drive(self, i: int) -> None:
        """No more torque from gimbal i's servo (its PD) nor its feedforward motor."""
        model, bus = self.plant.model, self.plant.bus
        servo = bus.gimbal_actuator_ids[i]
        model.actuator_gainprm[servo, :] = 0.0
        model.actuator_biasprm[servo, :] = 0.0
        if len(bus.gimbal_motor_ids):  # the feedforward servo's motors
            model.actuator_gear[bus.gimbal_motor_ids[i], :] = 0.0
