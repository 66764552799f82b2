"""The registry of stages by slot and name: `@stage(slot, name, Params)`, their parameters, the
design data they publish to each other, and their construction."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from testbed.errors import InputError, described
from testbed.exit_guard import os_exit_raises
from testbed.interrupts import from_a_signal
from testbed.registry import Registry
from testbed.run_core.stage_contract import SLOTS, Declared, StageContext, StageInfo

STAGES: dict[str, Registry] = {slot: Registry(slot) for slot in SLOTS}


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
    return Declared.of(stage_class(slot, name)).output


def stage_info(slot: str, name: str, params) -> StageInfo:
    """The stage's published design data: `design(params)`, and `outputs` from the class
    attribute of that name when the keys a stage returns do not depend on its parameters."""
    declared = Declared.of(stage_class(slot, name))
    design = {} if declared.design is None else dict(declared.design(params))
    if declared.outputs is not None:
        design.setdefault("outputs", declared.outputs)
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


def params_dict(params) -> dict:
    """A stage's parameters as a plain mapping (for the run summary)."""
    return dataclasses.asdict(params) if dataclasses.is_dataclass(params) else {}
