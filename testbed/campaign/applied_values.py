"""What a case actually ran with: each swept field read back from the built plant and the
constructed stages, and compared with the value the campaign set, so that a dispersion that
does not reach the simulation is an error in its row, never a silent nominal run.

Where a field is read from, first that applies:
- `Plant.applied()` (the compiled model and the initial state: bus inertia and mass, step,
  integrator, initial rate and attitude; a system adds its own);
- for `pipeline.SLOT.*`: the constructed stage, its `type_name` for `type`, its `applied()`
  (what it computed from its parameters, e.g. a sensor's axis or the seed its noise got),
  else the parameters it keeps (`stage.params`);
- else the validated scenario (testbed.scenario.loading.field_value): that value reached the
  parameters the system or stage was built from, but was not read back from it. `SOURCES`
  names the three, and a campaign's summary says which each field came from.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from testbed.errors import quoted
from testbed.run_core.stage_contract import Declared
from testbed.scenario.loading import field_value
from testbed.scenario.schema import is_number

SOURCES = ("model", "stage", "scenario")
RTOL = 1e-9  # unit conversions (deg <-> rad) and unit-vector normalisation change the last bits


class NotApplied(RuntimeError):
    """A swept field (`path`) whose read-back value differs from the value set."""

    def __init__(self, path: str, message: str):
        self.path = path
        super().__init__(message)


def read_back(path: str, scenario, plant_values: dict, stages: dict) -> tuple[Any, str]:
    """(value, source) of the field at dotted `path` as the run has it (see module doc)."""
    if path in plant_values:
        return _plain(plant_values[path]), "model"
    parts = path.split(".")
    if parts[0] == "pipeline" and len(parts) > 2 and parts[1] in stages:
        stage, key, rest = stages[parts[1]], parts[2], parts[3:]
        if key == "type" and not rest:
            return stage.type_name, "stage"
        declared = Declared.of(stage)
        own = {} if declared.applied is None else declared.applied()
        if key in own:
            return _descend(own[key], rest, path, scenario)
        params = declared.params
        if params is not None and key in getattr(params, "__dataclass_fields__", {}):
            return _descend(getattr(params, key), rest, path, scenario)
    return _plain(field_value(scenario, path)), "scenario"


def _descend(node, rest: list[str], path: str, scenario) -> tuple[Any, str]:
    for part in rest:
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif part in getattr(node, "__dataclass_fields__", {}):
            node = getattr(node, part)
        else:
            return _plain(field_value(scenario, path)), "scenario"
    return _plain(node), "stage"


def applied_values(values: dict, scenario, plant, stages: dict) -> dict[str, tuple[Any, str]]:
    """leaf path -> (value as run, source) for every swept field in `values` (a mapping value,
    e.g. a chosen `{type: ..., ...}` stage, is read key by key)."""
    plant_values = plant.applied()
    out = {}
    for path in leaf_paths(values):
        out[path] = read_back(path, scenario, plant_values, stages)
    return out


def leaf_paths(values: dict, prefix: str = "") -> list[str]:
    """The dotted paths of `values` with mappings opened up to their leaves."""
    paths = []
    for key, value in values.items():
        path = f"{prefix}{key}"
        paths += leaf_paths(value, path + ".") if isinstance(value, dict) and value else [path]
    return paths


def leaf_value(values: dict, path: str):
    """The value at leaf `path` of `leaf_paths(values)` (a field swept itself, or a key of a swept
    mapping above it: `model.faults.0.at_s` drawn into a drawn `model.faults.0`)."""
    if path in values:
        return values[path]
    for key, value in values.items():
        if isinstance(value, dict) and path.startswith(key + "."):
            try:
                return leaf_value(value, path[len(key) + 1:])
            except KeyError:
                continue
    raise KeyError(path)


def check_applied(values: dict, applied: dict[str, tuple[Any, str]]) -> None:
    """Raise NotApplied naming the first field whose read-back value differs from the value set."""
    for path, (value, source) in applied.items():
        wanted = leaf_value(values, path)
        if not agree(wanted, value):
            where = {"model": "the compiled model", "stage": "the constructed stage",
                     "scenario": "the validated scenario"}[source]
            raise NotApplied(path, f"{path} was set to {quoted(wanted)} but {where} has {quoted(value)}")


def agree(wanted, actual) -> bool:
    """Equal, numbers to RTOL relative (lists element by element, mappings key by key)."""
    if isinstance(wanted, dict):
        return isinstance(actual, dict) and all(k in actual and agree(v, actual[k]) for k, v in wanted.items())
    if isinstance(wanted, (list, tuple)):
        return (isinstance(actual, (list, tuple)) and len(actual) == len(wanted)
                and all(agree(w, a) for w, a in zip(wanted, actual)))
    if is_number(wanted) and is_number(actual):
        w, a = float(wanted), float(actual)
        return w == a or (math.isfinite(w) and abs(w - a) <= RTOL * max(abs(w), abs(a)))
    return wanted == actual


def _plain(value):
    """numpy values as plain Python (lists, floats, ints) for rows and comparison."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value
