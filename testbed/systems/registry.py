"""Physical systems by name (`model: {system: NAME, ...}`).

A system is one MJCF file in models/ and one package in testbed/systems/ that registers
itself with `@system(name, Params)` on its plant factory `make_plant(params, sim) -> Plant`.
`Params` is the system's one schema dataclass (units in the key names); its `system` field
holds the name.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from testbed.registry import Registry


@dataclass(frozen=True)
class System:
    params: type
    make_plant: Callable      # (params, sim: SimConfig) -> Plant
    free_flying: bool = True  # a free body with conserved total momentum when unactuated


SYSTEMS = Registry("system")


def system(name: str, params: type, free_flying: bool = True):
    """Register `make_plant(params, sim)` as system `name` with schema dataclass `params`."""

    def register(make_plant):
        SYSTEMS.add(name, System(params, make_plant, free_flying), make_plant.__module__)
        return make_plant

    return register


def load_params(config: dict, path: str):
    """(name, validated params) of a `model:` mapping (its `system` key is a field of the params)."""
    return SYSTEMS.load(config, path, "system", lambda entry: entry.params, keep_key=True)


def make_plant(scenario):
    return SYSTEMS[scenario.system].make_plant(scenario.model, scenario.sim)


def is_free_flying(scenario) -> bool:
    return SYSTEMS[scenario.system].free_flying
