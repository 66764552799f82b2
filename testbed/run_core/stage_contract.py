"""The control pipeline: sensor -> estimator -> control law -> allocator, chosen by name.

Each slot holds one stage, registered with `@stage(slot, name, Params)`
(testbed.run_core.stage_registry). Stages see only what their slot is given, so nothing
downstream of the sensor can read the true state:

- sensor     `measure(t, plant) -> dict`                 (the only stage that sees truth)
- estimator  `estimate(t, measurement, command) -> dict`  (`command`: last allocator output)
- law        `torque(t, estimate) -> dict`                (key `torque`: wanted body torque; a law
             whose class attribute `inputs` lists "internal_momentum" also gets that key:
             testbed.attitude_laws.momentum_input)
- allocator  `allocate(t, demand, estimate, actuators) -> dict`
             (key `gimbal_rates` or `body_torque`: what the plant's actuators receive)

Every key a stage returns is recorded under `<slot>/<key>`. What a stage may declare besides
its slot's method (its command key `output`, the keys it returns `outputs`, design data for the
other stages `design(params)`, `statistics` for the metrics, ...) is listed, with the default of
a stage that does not declare it, in `Declared`; the `StageContext` carries every slot's
`StageInfo`, so no stage reads another's parameters.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, Callable, Protocol

import numpy as np

from testbed.errors import InputError

SLOTS = ("sensor", "estimator", "law", "allocator")


@dataclass(frozen=True)
class StageInfo:
    """What the other stages may know of a configured stage: its type and published design data."""

    type: str
    design: dict = field(default_factory=dict)

    @property
    def outputs(self) -> frozenset:
        return frozenset(self.design.get("outputs", ()))


@dataclass(frozen=True)
class StageContext:
    """What a stage may know at construction: design data, never the running truth."""

    dt: float                   # physics step [s]
    control_period: float       # law and allocator period [s]
    inertia: np.ndarray         # spacecraft locked inertia about its CoM, body axes [kg m^2]
    internal_momentum: Any = None  # momentum of the moving parts relative to the bus at t = 0, body axes [N m s]
    sample_period: float | None = None  # sensor and estimator period [s], a divisor of control_period (None: the same)
    description: Any = None     # the plant's static design data (e.g. an actuator cluster's geometry)
    system: str = ""            # model.system
    free_flying: bool = True    # a free body with three rotational degrees of freedom
    model: Any = None           # the system's validated parameters
    initial: Any = None         # the scenario's initial state (attitude, rate)
    integrator: str = "RK4"
    end_time: float = float("inf")  # time of the run's last sample [s]
    stages: dict = field(default_factory=dict)  # slot -> StageInfo of every configured stage
    actuators: dict = field(default_factory=dict)  # what the actuators' encoders report at t = 0
    orbit: Any = None           # the scenario's orbit block (testbed.orbit.config.OrbitParams), or None


Signals = dict[str, np.ndarray]


@dataclass(frozen=True)
class Declared:
    """What a stage (its class or an instance) may declare besides its slot's method, each with
    the default a stage that does not declare it has. `Declared.of` is the one place that reads
    them; the run reads them once, when a stage takes its slot."""

    type_name: str | None = None       # the name it is registered under (`stage`); None: its class's name
    output: str | None = None          # allocator: the command key the plant takes (`Plant.actuators`)
    outputs: Any = None                # the keys it returns when they do not depend on its parameters
    #                                    (an estimator's "measurement": whatever its sensor measures)
    design: Callable | None = None     # classmethod design(params) -> dict published to the other stages
    inputs: tuple = ()                 # law: more it reads ("internal_momentum": the plant's H, body axes)
    needs_actuators: bool = True       # allocator: reads the actuators' read-outs (False: open loop)
    returns_nothing: bool = False      # a built-in empty slot, which the tick does not call
    statistics: dict | None = None     # counts over every control step that metrics read after the run
    params: Any = None                 # the validated parameters it was built from (a campaign reads them back)
    applied: Callable | None = None    # applied() -> {parameter: value as the stage runs it}, where that
    #                                    differs from `params` (testbed.campaign.applied_values)
    batched: Callable | None = None    # classmethod batched(stages) -> its form on many worlds' (N, ...)
    #                                    arrays (testbed.batch.stage_forms.BatchedForm), or None for
    #                                    stages it does not take; None: per world

    @classmethod
    def of(cls, stage) -> "Declared":
        return cls(**{name: getattr(stage, name, default) for name, default in _DECLARED_DEFAULTS})


_DECLARED_DEFAULTS = tuple((f.name, f.default) for f in dataclasses.fields(Declared))


class Sensor(Protocol):
    """Slot `sensor`: the only stage that sees the truth.

    measure(t [s], plant) -> {key: array}: what the instrument reports at t, e.g. a rate gyro
    `y` [rad/s]. It may read `plant.omega()` (body rate, body axes [rad/s]), `plant.quat()`
    (attitude (w, x, y, z), body to world) and a system's own read-outs."""

    def __init__(self, params, ctx: StageContext): ...

    def measure(self, t: float, plant) -> Signals: ...


class Estimator(Protocol):
    """Slot `estimator`: estimate(t, measurement, command) -> {key: array}; `measurement` is
    the sensor's dict at t, `command` the allocator's output of the previous tick (e.g.
    `body_torque` [N m] or `torque_delivered`). By convention `omega` [rad/s, body axes] and
    `quat` (w, x, y, z) when it estimates the attitude."""

    def __init__(self, params, ctx: StageContext): ...

    def estimate(self, t: float, measurement: Signals, command: Signals) -> Signals: ...


class Law(Protocol):
    """Slot `law`: torque(t, estimate) -> {"torque": (3,) wanted body torque [N m, body axes],
    ...anything else worth recording}."""

    inputs: tuple = ()  # "internal_momentum": also given the plant's internal momentum (Declared)

    def __init__(self, params, ctx: StageContext): ...

    def torque(self, t: float, estimate: Signals) -> Signals: ...


class Allocator(Protocol):
    """Slot `allocator`: allocate(t, demand, estimate, actuators) -> command. `demand` is the
    law's dict, `actuators` what the plant's encoders report (e.g. `gimbal_angle` [rad],
    `rotor_rate` [rad/s]). The class attribute `output` names the command key the plant takes
    (`body_torque` (3,) [N m], `gimbal_rates` (4,) [rad/s], ...: `Plant.actuators`); the command
    is held over the control period. A built-in allocator may hand a command as a list of plain
    floats (what the plant's servo computes with), which the trace records like an array."""

    output: str | None = None    # the command key (Declared)
    needs_actuators: bool = True  # False: an open-loop command, given no read-outs (Declared)

    def __init__(self, params, ctx: StageContext): ...

    def allocate(self, t: float, demand: Signals, estimate: Signals, actuators: Signals) -> Signals: ...


def require_free_body(ctx: StageContext, slot: str, name: str) -> None:
    """Refuse a stage that needs a free three-axis body on a system that is not one."""
    if not ctx.free_flying:
        raise InputError(f"pipeline.{slot}.type", f"{name} needs a free-flying system (a body with three "
                                                  f"rotational degrees of freedom), not model.system {ctx.system}")


def require_attitude_estimate(ctx: StageContext, name: str) -> None:
    """Refuse a law that reads the attitude and rate with an estimator that does not give them."""
    if not {"quat", "omega"} <= ctx.stages["estimator"].outputs:
        raise InputError("pipeline.estimator.type", f"{name} needs an estimator that gives quat and omega "
                                                    "(e.g. sensor ideal_attitude with estimator attitude)")


class StageFailed(RuntimeError):
    """A stage raised, or returned something that is not a dict of finite arrays of steady shape;
    `method`: the stage raised MethodFailed, its method left the conditions it is valid in."""

    def __init__(self, time: float, slot: str, name: str, reason: str, method: bool = False):
        self.time, self.slot, self.name, self.method = time, slot, name, method
        what = "left its validity" if method else "failed"
        super().__init__(f"stage {slot} {name!r} {what} at t = {time:.6g} s: {reason}")


class MethodFailed(Exception):
    """Raised by a stage whose method has left the conditions it is valid in (an observer whose
    error dynamics diverge, a filter without fixes for longer than its error model holds): the
    method's own limit, not a fault of the code. `reason` names the criterion and its numbers;
    the run ends with status "method_failed" (testbed.run_core.result.RunResult)."""

    def __init__(self, reason: str):
        self.reason = reason
        super().__init__(reason)
