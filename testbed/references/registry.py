"""Analytic reference models a scenario's truth is compared with (`reference: {type: NAME}`).

A reference registers with `@reference(name, systems, Params)` on its `prepare(plant, params)`,
usually in the package of the system it describes. It is prepared from the plant at t = 0
(design data and initial state, never the later truth) and returns
`evaluate(times, recorder) -> omega (N, 3)`, run at the trace sample times after the run;
it may read recorded inputs (e.g. actuator histories) from the recorder. A reference of a
closed loop (`with_scenario=True`) is prepared as `prepare(plant, params, scenario)`: it reads the
stages' validated parameters (design data, like the plant's) to build the same loop.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable

from testbed.errors import InputError
from testbed.registry import Registry


@dataclass
class _NoParams:
    pass


@dataclass(frozen=True)
class ReferenceKind:
    systems: tuple[str, ...]
    params: type
    prepare: Callable   # (plant, params[, scenario]) -> evaluate(times, recorder) -> omega (N, 3)
    with_scenario: bool = False


REFERENCES = Registry("reference")


@dataclass(frozen=True)
class DeclaredReference:
    """What a prepared reference may declare besides `evaluate(times, recorder)`, each with the
    default it otherwise has; `DeclaredReference.of` is the one place that reads them.

    update, finish: a streaming reference's `update(chunk) -> Chunk | None` of the rows of each
    chunk of the run, and `finish() -> Chunk | None` of the last ones (then it is not called
    whole, testbed.recording.reference_windows); signals: the recorded keys a reference evaluated
    on the whole run reads besides `truth/omega` (None: it may read every signal)."""

    update: Callable | None = None
    finish: Callable | None = None
    signals: tuple | None = None

    @classmethod
    def of(cls, reference) -> "DeclaredReference":
        return cls(**{f.name: getattr(reference, f.name, f.default) for f in dataclasses.fields(cls)})

    @property
    def streaming(self) -> bool:
        return self.update is not None


def reference(name: str, systems: tuple[str, ...], params: type = _NoParams, with_scenario: bool = False):
    def register(prepare):
        REFERENCES.add(name, ReferenceKind(systems, params, prepare, with_scenario), prepare.__module__)
        return prepare

    return register


def load_params(config: dict, path: str):
    """(name, validated params) of a `reference:` mapping."""
    return REFERENCES.load(config, path, "type", lambda kind: kind.params)


def check_system(scenario) -> None:
    if scenario.reference is None:
        return
    name, _ = scenario.reference
    allowed = REFERENCES[name].systems
    if scenario.system not in allowed:
        raise InputError("reference.type", f"{name} needs model.system in {list(allowed)}, got {scenario.system!r}")


def prepare(scenario, plant):
    name, params = scenario.reference
    kind = REFERENCES[name]
    return kind.prepare(plant, params, scenario) if kind.with_scenario else kind.prepare(plant, params)
