"""The control pipeline: sensor -> estimator -> control law -> allocator, chosen by name.

Each slot holds one stage, registered with `@stage(slot, name, Params)`. Stages see only
what their slot is given, so nothing downstream of the sensor can read the true state:

- sensor     `measure(t, plant) -> dict`                 (the only stage that sees truth)
- estimator  `estimate(t, measurement, command) -> dict`  (`command`: last allocator output)
- law        `torque(t, estimate) -> dict`                (key `torque`: wanted body torque)
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
from typing import Any

import numpy as np

from testbed import schema
from testbed.errors import InputError
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
    control_period: float       # pipeline sample period [s]
    inertia: np.ndarray         # spacecraft locked inertia about its CoM, body axes [kg m^2]
    description: Any = None     # the plant's static design data (e.g. an actuator cluster's geometry)
    system: str = ""            # model.system
    model: Any = None           # the system's validated parameters
    initial: Any = None         # the scenario's initial state (attitude, rate)
    integrator: str = "RK4"
    end_time: float = float("inf")  # time of the run's last sample [s]
    stages: dict = field(default_factory=dict)  # slot -> StageInfo of every configured stage


def stage(slot: str, name: str, params_cls: type | None = None):
    """Register a stage class under `name` in `slot`; `params_cls` is its schema dataclass."""

    def register(cls):
        STAGES[slot].add(name, (params_cls or _NoParams, cls))
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
    """Validate a slot's `{type: NAME, ...params}` mapping; returns (name, params)."""
    config = dict(config or {"type": "none"})
    name = config.pop("type", None)
    if name is None:
        raise InputError(f"{path}.type", f"is required (one of {', '.join(names(slot))})")
    params_cls, _ = STAGES[slot].lookup(name, f"{path}.type")
    return name, schema.load(params_cls, config, path)


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


def build(slot: str, name: str, params, ctx: StageContext):
    return stage_class(slot, name)(params, ctx)


class Pipeline:
    """One control tick: run the four stages in order and hand the command to the plant."""

    def __init__(self, sensor, estimator, law, allocator):
        self.sensor, self.estimator, self.law, self.allocator = sensor, estimator, law, allocator
        self.command: dict[str, np.ndarray] = {}
        # open-loop allocators ignore the actuator read-outs: skip reading them
        self._needs_actuators = getattr(allocator, "needs_actuators", True)

    @classmethod
    def from_config(cls, configs: dict, ctx: StageContext) -> "Pipeline":
        stages = [build(slot, *configs[slot], ctx) for slot in SLOTS]
        return cls(*stages)

    def stages(self) -> dict:
        return dict(zip(SLOTS, (self.sensor, self.estimator, self.law, self.allocator)))

    def tick(self, t: float, plant) -> dict[str, dict[str, np.ndarray]]:
        measurement = self.sensor.measure(t, plant)
        estimate = self.estimator.estimate(t, measurement, self.command)
        demand = self.law.torque(t, estimate)
        actuators = plant.actuator_state() if self._needs_actuators else {}
        self.command = self.allocator.allocate(t, demand, estimate, actuators)
        plant.apply(self.command)
        return {"sensor": measurement, "estimator": estimate, "law": demand, "allocator": self.command}


def params_dict(params) -> dict:
    """A stage's parameters as a plain mapping (for the run summary)."""
    return dataclasses.asdict(params) if dataclasses.is_dataclass(params) else {}


