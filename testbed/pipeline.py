"""The control pipeline: sensor -> estimator -> control law -> allocator, chosen by name.

Each slot holds one stage, registered with `@stage(slot, name, Params)`. Stages see only
what their slot is given, so nothing downstream of the sensor can read the true state:

- sensor     `measure(t, plant) -> dict`                 (the only stage that sees truth)
- estimator  `estimate(t, measurement, command) -> dict`  (`command`: last allocator output)
- law        `torque(t, estimate) -> dict`                (key `torque`: wanted body torque; a law
             whose class attribute `inputs` lists "internal_momentum" also gets that key:
             testbed.attitude_laws.momentum_input)
- allocator  `allocate(t, demand, estimate, actuators) -> dict`
             (key `gimbal_rates` or `body_torque`: what the plant's actuators receive)

Every key a stage returns is recorded under `<slot>/<key>`. A stage class may publish
design data for the other stages with a classmethod `design(params) -> dict` (by
convention `outputs`: the keys it returns; a class attribute `outputs` says the same for a
stage whose keys do not depend on its parameters); the `StageContext` carries every slot's
`StageInfo`, so no stage reads another's parameters. A stage may keep `statistics` (a dict
of counts over every control step) that metrics read after the run.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from testbed.errors import InputError, described, quoted, refused_as
from testbed.exit_guard import os_exit_raises
from testbed.interrupts import from_a_signal
from testbed.registry import Registry

SLOTS = ("sensor", "estimator", "law", "allocator")
STAGES: dict[str, Registry] = {slot: Registry(slot) for slot in SLOTS}


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

    def __init__(self, params, ctx: StageContext): ...

    def torque(self, t: float, estimate: Signals) -> Signals: ...


class Allocator(Protocol):
    """Slot `allocator`: allocate(t, demand, estimate, actuators) -> command. `demand` is the
    law's dict, `actuators` what the plant's encoders report (e.g. `gimbal_angle` [rad],
    `rotor_rate` [rad/s]). The class attribute `output` names the command key the plant takes
    (`body_torque` (3,) [N m], `gimbal_rates` (4,) [rad/s], ...: `Plant.actuators`); the command
    is held over the control period. A built-in allocator may hand a command as a list of plain
    floats (what the plant's servo computes with), which the trace records like an array."""

    output: str

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


def stage(slot: str, name: str, params_cls: type | None = None):
    """Register a stage class under `name` in `slot`; `params_cls` is its schema dataclass."""

    def register(cls):
        STAGES[slot].add(name, (params_cls or _NoParams, cls), cls.__module__)
        cls.slot = slot
        cls.type_name = name
        return cls

    return register


@dataclass
class _NoParams:
    pass


def names(slot: str) -> list[str]:
    return STAGES[slot].names()


def load_params(slot: str, config: dict | None, path: str):
    """Validate a slot's `{type: NAME, ...params}` mapping (absent: type none); returns (name, params)."""
    return STAGES[slot].load({"type": "none"} if config is None else config, path, "type", lambda entry: entry[0])


def stage_class(slot: str, name: str) -> type:
    return STAGES[slot][name][1]


def output_of(slot: str, name: str) -> str | None:
    """The command key a registered stage produces (allocators: `body_torque`, `gimbal_rates`, ...)."""
    return getattr(stage_class(slot, name), "output", None)


def stage_info(slot: str, name: str, params) -> StageInfo:
    """The stage's published design data: `design(params)`, and `outputs` from the class
    attribute of that name when the keys a stage returns do not depend on its parameters."""
    cls = stage_class(slot, name)
    design = dict(cls.design(params)) if hasattr(cls, "design") else {}
    if hasattr(cls, "outputs"):
        design.setdefault("outputs", cls.outputs)
    return StageInfo(name, design)


def stage_infos(configs: dict) -> dict[str, StageInfo]:
    """slot -> StageInfo of a scenario's four stages; an estimator that passes the measurement
    on (design outputs "measurement") outputs what its sensor does."""
    infos = {slot: stage_info(slot, *configs[slot]) for slot in SLOTS}
    estimator = infos["estimator"]
    if estimator.design.get("outputs") == "measurement":
        infos["estimator"] = StageInfo(estimator.type, estimator.design | {"outputs": infos["sensor"].outputs})
    return infos


def build(slot: str, name: str, params, ctx: StageContext):
    """The stage `name` of `slot` constructed; a plug-in stage whose constructor fails (raises
    anything, exits the process) is bad input naming the slot, before anything runs."""
    cls = stage_class(slot, name)
    if cls.__module__.startswith("testbed."):
        return cls(params, ctx)
    try:
        with os_exit_raises():
            return cls(params, ctx)
    except InputError:
        raise
    except BaseException as exc:
        if from_a_signal(exc):
            raise
        raise InputError(f"pipeline.{slot}", f"{name} cannot be built: {described(exc)}") from None


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
    the run ends with status "method_failed" (testbed.runner.RunResult)."""

    def __init__(self, reason: str):
        self.reason = reason
        super().__init__(reason)


# Keys whose shape the slot's interface fixes (see the module doc); a command key's shape
# comes from the plant (`Plant.actuators`).
INTERFACE_SHAPES = {"law": {"torque": (3,)}}


class OutputCheck:
    """Checks one stage's output at every tick: a dict with its declared `outputs` keys, each a
    finite real array whose shape is the interface's, or else the one it had at the first tick.
    Applied to stages from outside the package (plug-ins); the built-ins are tested instead."""

    def __init__(self, slot: str, name: str, required=(), shapes: dict | None = None):
        # the slot's interface keys are required whatever the stage declares (a law's `torque`:
        # a law without it would leave the allocator no demand, and the run would pass on none)
        self.slot, self.name = slot, name
        self.required = tuple(dict.fromkeys((*required, *INTERFACE_SHAPES.get(slot, {}))))
        self.shapes = dict(shapes or {})

    def __call__(self, t: float, out) -> None:
        if not isinstance(out, dict):
            raise StageFailed(t, self.slot, self.name, f"returned {type(out).__name__}, not a dict of arrays")
        for key in self.required:
            if key not in out:
                raise StageFailed(t, self.slot, self.name, f"missing key {key!r} (a {self.slot} returns "
                                  f"{', '.join(map(repr, self.required))})")
        for key, value in out.items():
            try:
                array = np.asarray(value)
                kind = array.dtype.kind
                if kind != "f":
                    if kind == "c":  # float() of it would drop the imaginary part
                        raise StageFailed(t, self.slot, self.name, f"returned a complex {key!r}: {quoted(value)}")
                    if kind not in "biuO":  # text, dates: not numbers, though float() may read them
                        raise TypeError
                    array = array.astype(float)
            except (TypeError, ValueError, OverflowError):
                raise StageFailed(t, self.slot, self.name, f"key {key!r} is not numeric: {quoted(value)}") from None
            expected = self.shapes.setdefault(key, array.shape)
            if array.shape != expected:
                raise StageFailed(t, self.slot, self.name, f"key {key!r} has shape {array.shape}, expected {expected}")
            if not np.all(np.isfinite(array)):
                raise StageFailed(t, self.slot, self.name, f"key {key!r} is not finite: {array.tolist()}")


def _is_builtin(stage_object) -> bool:
    return type(stage_object).__module__.startswith("testbed.")


def _returns_nothing(stage_object) -> bool:
    """A built-in stage that always returns nothing (an empty slot): the tick skips it."""
    return _is_builtin(stage_object) and getattr(type(stage_object), "returns_nothing", False)


class Pipeline:
    """One control tick: run the four stages in order and hand the command to the plant.

    A stage that raises (anything but Ctrl-C or SIGTERM arriving: sys.exit and os._exit too,
    testbed.exit_guard), or a plug-in stage whose output fails its `OutputCheck`, stops the
    run with `StageFailed` naming the stage, the time and the reason. The tick builds
    nothing it does not need: a built-in empty slot (`none`, which returns nothing) is not
    called, a built-in stage's output is not checked, and the outputs stay where the stages
    left them (`measurement`, `estimate`, `demand`, `command`) until `signals()` gathers
    them for a trace sample. When the allocator is the only stage that runs (an open-loop
    command), `tick` is `_allocate`, which asks nothing of the empty slots."""

    def __init__(self, sensor, estimator, law, allocator, checks: dict | None = None):
        self.sensor, self.estimator, self.law, self.allocator = sensor, estimator, law, allocator
        self.measurement: dict[str, np.ndarray] = {}
        self.estimate: dict[str, np.ndarray] = {}
        self.demand: dict[str, np.ndarray] = {}
        self.command: dict[str, np.ndarray] = {}
        self.checks = dict(checks or {})
        self._wire()

    def _wire(self) -> None:
        """Which stages the tick calls and checks, from the stages and checks now in place."""
        # open-loop allocators ignore the actuator read-outs: skip reading them
        self._needs_actuators = getattr(self.allocator, "needs_actuators", True)
        # a law that compensates w x H itself reads the internal momentum (testbed.attitude_laws.momentum_input)
        self._law_reads_momentum = "internal_momentum" in getattr(self.law, "inputs", ())
        self._sensing, self._estimating, self._controlling, self._allocating = (
            not _returns_nothing(stage_object) for stage_object in self.stages().values())
        self._sensor_check, self._estimator_check, self._law_check, self._allocator_check = (
            self.checks.get(slot) for slot in SLOTS)
        self.__dict__.pop("tick", None)
        if self._allocating and not (self._sensing or self._estimating or self._controlling):
            self.tick = self._allocate  # an open-loop command: the allocator alone

    def set_stage(self, slot: str, stage_object, check: "OutputCheck | None") -> None:
        """Put `stage_object` in `slot`, its output checked by `check` at every tick (None: not
        checked), in place of the stage there (testbed.stepping: a Python object as a stage, or
        a command given for one step)."""
        setattr(self, slot, stage_object)
        self.checks.pop(slot, None)
        if check is not None:
            self.checks[slot] = check
        self._wire()

    @classmethod
    def from_config(cls, configs: dict, ctx: StageContext, actuators: dict | None = None) -> "Pipeline":
        """The four stages of `configs` (slot -> (name, params)); plug-in stages get an
        `OutputCheck` (an allocator's command keys take their shapes from `actuators`)."""
        stages = []
        for slot in SLOTS:
            # a slot is built from its own parameters and what the others publish (ctx.stages)
            with refused_as(f"pipeline.{slot}", configs[slot][0], {f"pipeline.{s}": configs[s][1] for s in SLOTS}):
                stages.append(build(slot, *configs[slot], ctx))
        checks = {}
        for slot, stage_object in zip(SLOTS, stages):
            if _is_builtin(stage_object):
                continue
            name = configs[slot][0]
            required = ctx.stages[slot].outputs if slot in ctx.stages else ()
            output = getattr(stage_object, "output", None)
            shapes = dict(INTERFACE_SHAPES.get(slot, {}))
            if slot == "allocator" and output is not None:
                required = tuple(required) + (output,)
                shapes[output] = (actuators or {}).get(output)
                shapes = {k: v for k, v in shapes.items() if v is not None}
            checks[slot] = OutputCheck(slot, name, required, shapes)
        return cls(*stages, checks=checks)

    def stages(self) -> dict:
        return dict(zip(SLOTS, (self.sensor, self.estimator, self.law, self.allocator)))

    def tick(self, t: float, plant) -> None:
        """Sensor, estimator, law and allocator at time t, then the command to the plant."""
        self.sense(t, plant)
        slot = "law"
        try:
            if self._controlling:
                given = self.estimate
                if self._law_reads_momentum:
                    given = given | {"internal_momentum": plant.internal_momentum_body()}
                self.demand = self.law.torque(t, given)
                if self._law_check is not None:
                    self._law_check(t, self.demand)
            slot = "allocator"
            if self._allocating:
                actuators = plant.actuator_state() if self._needs_actuators else {}
                self.command = self.allocator.allocate(t, self.demand, self.estimate, actuators)
                if self._allocator_check is not None:
                    self._allocator_check(t, self.command)
            plant.apply(self.command)
        except StageFailed:
            raise
        except BaseException as exc:  # the stage's own failure, sys.exit too: name it, keep the trace so far
            if from_a_signal(exc):
                raise
            raise self._failed(t, slot, exc) from exc

    def _allocate(self, t: float, plant) -> None:
        """`tick` when the allocator is the only stage that runs: the same, with nothing to skip."""
        try:
            self.command = self.allocator.allocate(t, self.demand, self.estimate,
                                                   plant.actuator_state() if self._needs_actuators else {})
            if self._allocator_check is not None:
                self._allocator_check(t, self.command)
            plant.apply(self.command)
        except StageFailed:
            raise
        except BaseException as exc:
            if from_a_signal(exc):
                raise
            raise self._failed(t, "allocator", exc) from exc

    def _failed(self, t: float, slot: str, exc: BaseException) -> StageFailed:
        stage_object = getattr(self, slot)
        name = getattr(stage_object, "type_name", type(stage_object).__name__)
        if isinstance(exc, MethodFailed):
            return StageFailed(t, slot, name, exc.reason, method=True)
        return StageFailed(t, slot, name, described(exc))

    def sense(self, t: float, plant) -> None:
        """Sensor and estimator at time t: the first half of `tick`, and alone a sample between
        two control instants when they run faster than the law (`sim.estimator_period_s`),
        the command staying held."""
        slot = "sensor"
        try:
            if self._sensing:
                self.measurement = self.sensor.measure(t, plant)
                if self._sensor_check is not None:
                    self._sensor_check(t, self.measurement)
            slot = "estimator"
            if self._estimating:
                self.estimate = self.estimator.estimate(t, self.measurement, self.command)
                if self._estimator_check is not None:
                    self._estimator_check(t, self.estimate)
        except StageFailed:
            raise
        except BaseException as exc:
            if from_a_signal(exc):
                raise
            raise self._failed(t, slot, exc) from exc

    def sensed_signals(self) -> dict[str, dict[str, np.ndarray]]:
        """The sensor's and estimator's last outputs, as the trace records them between control instants."""
        return {"sensor": self.measurement, "estimator": self.estimate}

    def signals(self) -> dict[str, dict[str, np.ndarray]]:
        """The last tick's outputs by slot, as the trace records them."""
        return {"sensor": self.measurement, "estimator": self.estimate, "law": self.demand,
                "allocator": self.command}


def params_dict(params) -> dict:
    """A stage's parameters as a plain mapping (for the run summary)."""
    return dataclasses.asdict(params) if dataclasses.is_dataclass(params) else {}


