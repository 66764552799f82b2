"""Scenario files: a YAML experiment validated into a typed `Scenario`.

Layout (every key optional unless marked; units are in the key names, SI and radians inside):

    name: str                       # required
    description: str
    plugins: [FILE.py | module]     # user code that registers stages, systems, metrics (testbed.plugins)
    model: {system: NAME, ...}      # required: the physical system and its parameters (testbed.systems)
    initial: {omega_deg_s | omega_rad_s: [3], quat: [w, x, y, z]}
    sim: {duration_s (required), dt_s, integrator, control_period_s, estimator_period_s, trace_period_s, trace_envelope_s}
    pipeline: {sensor|estimator|law|allocator: {type: NAME, ...params}}   (testbed.pipeline)
    reference: {type: NAME, ...}    # an analytic model the truth is compared with
    checks: {METRIC: {max: X} | {min: X}}
    accuracy: {enabled, step_angle_max_rad, ...}   # the accuracy guard's thresholds (testbed.accuracy.settings)
    sweep: {grid: {PATH: [values]}, dispersions: {PATH: {normal: [mean, sigma]}}, samples, seed}   (testbed.campaign.spec)
    orbit: {altitude_km | semi_major_axis_km | tle, ...}   (testbed.orbit.config; a free-flying system)
    environment: {gravity_gradient, drag, solar_pressure, magnetic_field, ...}   (testbed.environment.config)

`load_scenario(path, overrides)` applies `--set key.path=value` overrides to the raw mapping
first, so they are validated exactly like the file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from testbed import metrics, pipeline
from testbed.references import registry as references_registry
from testbed.scenario import schema
from testbed.systems import registry as systems_registry
from testbed.errors import InputError, quoted
from testbed.math.validation import existing_file, unit_quaternion
from testbed.plugins import discover, load_plugins
from testbed.scenario.yaml_reading import read_yaml, yaml_load
from testbed.scenario.schema import param
from testbed.scenario.shipped_files import SCENARIO_DIR
from testbed.campaign.spec import load_spec
from testbed.environment.config import ENVIRONMENT_SIGNALS, EnvironmentParams
from testbed.orbit.config import ORBIT_SIGNALS, OrbitParams
from testbed.accuracy.settings import AccuracySettings
from testbed.run_core.timing import Timing



# Resource caps, decided before a run: about an hour of physics at 1e5-3e5 steps/s, and a trace
# that fits in memory (about 1.2 kB a sample for the CMG spacecraft: 2.4 GB at the cap).
MAX_PHYSICS_STEPS = 1_000_000_000
MAX_TRACE_SAMPLES = 2_000_000


@dataclass(kw_only=True)
class SimConfig:
    duration_s: float = param(gt=0, doc="simulated time")
    dt_s: float = param(0.002, gt=0, le=1.0, doc="physics step")
    integrator: Literal["RK4", "Euler", "implicit", "implicitfast"] = "RK4"
    control_period_s: float | None = param(None, gt=0, doc="law and allocator period (default dt_s)")
    estimator_period_s: float | None = param(None, gt=0, doc=(
        "sensor and estimator period, a whole divisor of control_period_s (default: control_period_s)"))
    trace_period_s: float | None = param(None, gt=0, doc="trace sample period (default control period)")
    trace_envelope_s: float | None = param(None, gt=0, doc="the .rrd holds each signal's min and max over windows "
                                           "of this length instead of every sample (docs/trace.md \"Long runs\")")

    def validate(self, path: str) -> None:
        if self.control_period_s is None:
            self.control_period_s = self.dt_s
        if self.estimator_period_s is None:
            self.estimator_period_s = self.control_period_s
        if self.trace_period_s is None:
            self.trace_period_s = self.control_period_s
        # the whole counts between the periods are the run's (testbed.run_core.timing.Timing): checked here
        schema.whole_multiple(self.control_period_s, self.dt_s, schema.join(path, "control_period_s"), "dt_s")
        schema.whole_multiple(self.estimator_period_s, self.dt_s, schema.join(path, "estimator_period_s"), "dt_s")
        samples_per_tick = schema.whole_multiple(self.control_period_s, self.estimator_period_s,
                                                 schema.join(path, "control_period_s"), "estimator_period_s")
        schema.whole_multiple(self.trace_period_s, self.estimator_period_s, schema.join(path, "trace_period_s"),
                              "control_period_s" if samples_per_tick == 1 else "estimator_period_s")
        if self.trace_envelope_s is not None:
            schema.whole_multiple(self.trace_envelope_s, self.trace_period_s, schema.join(path, "trace_envelope_s"),
                                  "trace_period_s")
        steps_total = self.duration_s / self.dt_s
        if steps_total > MAX_PHYSICS_STEPS:
            raise InputError(schema.join(path, "duration_s"), f"{self.duration_s:g} s at dt_s = {self.dt_s:g} s is "
                             f"{steps_total:.3g} physics steps; at most {MAX_PHYSICS_STEPS:.0e}: shorten the run "
                             "or raise dt_s")
        samples = self.duration_s / self.trace_period_s
        if samples > MAX_TRACE_SAMPLES:
            raise InputError(schema.join(path, "trace_period_s"), f"the run would record {samples:.3g} trace samples; "
                             f"at most {MAX_TRACE_SAMPLES:.0e}: raise trace_period_s to at least "
                             f"{self.duration_s / MAX_TRACE_SAMPLES:.3g} s")
        schema.whole_multiple(self.duration_s, self.control_period_s, schema.join(path, "duration_s"), "control_period_s")

    @property
    def end_time_s(self) -> float:
        """Time of the run's last trace sample, the final state [s], as the run loop records it
        (testbed.run_core.timing.Timing.end_time_s)."""
        return Timing.of(self).end_time_s


@dataclass
class InitialState:
    omega_deg_s: list[float] | None = param(None, length=3, doc="body rate, body axes")
    omega_rad_s: list[float] | None = param(None, length=3, doc="body rate, body axes")
    quat: list[float] = param([1.0, 0.0, 0.0, 0.0], length=4, doc="attitude (w, x, y, z), body to world")

    def validate(self, path: str) -> None:
        if self.omega_deg_s is not None and self.omega_rad_s is not None:
            raise InputError(schema.join(path, "omega_deg_s"), "give omega_deg_s or omega_rad_s, not both")
        self.quat = list(unit_quaternion(schema.join(path, "quat"), self.quat))

    @property
    def omega(self) -> np.ndarray:
        if self.omega_rad_s is not None:
            return np.array(self.omega_rad_s, dtype=float)
        return np.deg2rad(self.omega_deg_s or [0.0, 0.0, 0.0])


@dataclass
class CheckLimit:
    max: float | None = None
    min: float | None = None

    def validate(self, path: str) -> None:
        if self.max is None and self.min is None:
            raise InputError(path, "give max or min")

    def passed(self, value: float) -> bool:
        if not np.isfinite(value):
            return False
        return (self.max is None or value <= self.max) and (self.min is None or value >= self.min)

    @property
    def text(self) -> str:
        """`<= max and >= min`, each limit exactly (at 6 figures when they hold it, else in full)."""
        def exact(x: float) -> str:
            return f"{x:g}" if float(f"{x:g}") == x else repr(float(x))

        parts = ([f"<= {exact(self.max)}"] if self.max is not None else []) + (
            [f">= {exact(self.min)}"] if self.min is not None else [])
        return " and ".join(parts)


@dataclass(kw_only=True)
class _RawScenario:
    name: str
    description: str = ""
    plugins: list[str] = param([], doc="plug-in .py files (relative to this file) or module names")
    model: dict[str, Any]
    initial: InitialState = field(default_factory=InitialState)
    sim: SimConfig = param()
    pipeline: dict[str, Any] = param({})
    reference: dict[str, Any] | None = None
    checks: dict[str, Any] = param({})      # each a CheckLimit, read once its metric is known
    accuracy: AccuracySettings = field(default_factory=AccuracySettings)
    sweep: dict[str, Any] | None = None     # testbed.campaign.cases expands it; `run` ignores it
    orbit: dict[str, Any] | None = None     # testbed.orbit.config.OrbitParams
    environment: dict[str, Any] | None = None  # testbed.environment.config.EnvironmentParams


@dataclass
class Scenario:
    """A validated scenario: every part typed, stage and system parameters included."""

    name: str
    description: str
    system: str
    model: Any                              # the system's params dataclass
    initial: InitialState
    sim: SimConfig
    stages: dict[str, tuple[str, Any]]      # slot -> (stage name, params)
    reference: tuple[str, Any] | None       # (reference name, params)
    checks: dict[str, CheckLimit]
    source: str = ""
    orbit: Any = None                       # OrbitParams, or None: no orbit
    environment: Any = None                 # EnvironmentParams, or None: no environment torque
    accuracy: AccuracySettings = field(default_factory=AccuracySettings)  # the accuracy guard's thresholds


def parse(data: dict, source: str = "") -> Scenario:
    """Validate a raw scenario mapping (see module doc) into a `Scenario`."""
    discover()
    raw = schema.load(_RawScenario, data)
    load_plugins(raw.plugins, Path(source).parent if source else Path.cwd())
    if raw.sweep is not None:  # the block itself is checked here; its cases by testbed.campaign.cases
        load_spec(raw.sweep)
    system_name, model = systems_registry.load_params(raw.model, "model")
    unknown = set(raw.pipeline) - set(pipeline.SLOTS)
    if unknown:
        key = sorted(unknown)[0]
        raise InputError(f"pipeline.{key}", f"unknown slot (known: {', '.join(pipeline.SLOTS)})")
    stages = {slot: pipeline.load_params(slot, raw.pipeline.get(slot), f"pipeline.{slot}")
              for slot in pipeline.SLOTS}
    reference = None
    if raw.reference is not None:
        reference = references_registry.load_params(raw.reference, "reference")
    scenario = Scenario(raw.name, raw.description, system_name, model, raw.initial, raw.sim,
                        stages, reference, {}, source, *_orbit_blocks(raw, system_name), raw.accuracy)
    # after the scenario exists (its metrics depend on it): first that each check names one of
    # them, then its limits, so that `checks.typo.max` is refused as a metric, not as a limit
    metrics.validate_checks(scenario, raw.checks)
    scenario.checks = {name: schema.load(CheckLimit, limits, f"checks.{name}") for name, limits in raw.checks.items()}
    return scenario


# Scenario blocks `testbed describe block` lists: their schema and the trace signals they add.
SCENARIO_BLOCKS = {"orbit": (OrbitParams, ORBIT_SIGNALS), "environment": (EnvironmentParams, ENVIRONMENT_SIGNALS),
                   "accuracy": (AccuracySettings, ())}


def _orbit_blocks(raw: _RawScenario, system_name: str) -> tuple:
    """The validated `orbit:` and `environment:` blocks (None when absent)."""
    orbit = None if raw.orbit is None else schema.load(OrbitParams, raw.orbit, "orbit")
    environment = None if raw.environment is None else schema.load(EnvironmentParams, raw.environment, "environment")
    if environment is not None and orbit is None:
        raise InputError("environment", "the environment needs an orbit: add an orbit: block")
    if orbit is not None and not systems_registry.SYSTEMS[system_name].free_flying:
        raise InputError("orbit", f"model.system {system_name} is not a free-flying system")
    if orbit is not None:  # the grid state after the run's end is read too
        orbit.check_propagates("orbit", ((math.floor(raw.sim.end_time_s / orbit.step_s) + 1) * orbit.step_s,))
    return orbit, environment


def resolve_path(name_or_path: str) -> Path:
    """A scenario file by path, or by name from the project's scenarios/ folder."""
    path = Path(name_or_path)
    if existing_file("scenario", path):
        return path
    candidate = SCENARIO_DIR / (name_or_path if name_or_path.endswith(".yaml") else f"{name_or_path}.yaml")
    if existing_file("scenario", candidate):
        return candidate
    raise InputError("scenario", f"no such file or scenario name: {name_or_path}")


def apply_override(data: dict, assignment: str) -> None:
    """Apply one `key.path=value` override in place; the value is parsed as YAML."""
    if not isinstance(assignment, str):
        raise InputError("--set", f"expected key.path=value (a string), got {type(assignment).__name__}")
    if "=" not in assignment:
        raise InputError("--set", f"expected key.path=value, got {quoted(assignment)}")
    key, text = assignment.split("=", 1)
    if not all(key.strip().split(".")):
        raise InputError("--set", f"bad key path {key!r}")
    if not text.strip():  # `KEY=` removes the key: its default stands (`KEY=null` sets null)
        remove_field(data, key.strip())
        return
    set_field(data, key.strip(), yaml_load(text, f"--set {key}"))


def remove_field(data: dict, path: str) -> None:
    """Remove the key at dotted `path` of a raw scenario mapping, in place (nothing when it is absent;
    an item of a list cannot be removed: its place would shift the others)."""
    parts = path.split(".")
    node = data
    for i, part in enumerate(parts[:-1]):
        node = _list_item(node, part, parts[: i + 1]) if isinstance(node, list) else node.get(part)
        if node is None:
            return
        if not isinstance(node, (dict, list)):
            raise InputError(".".join(parts[: i + 1]), "is not a mapping, cannot remove a key below it")
    if isinstance(node, list):
        raise InputError(path, "an item of a list cannot be removed; set the whole list")
    node.pop(parts[-1], None)


def set_field(data: dict, path: str, value) -> None:
    """Set the field at dotted `path` of a raw scenario mapping to `value`, in place (mappings
    on the way are created; a number picks an existing item of a list: `model.faults.0.at_s`)."""
    parts = path.split(".")
    node = data
    for i, part in enumerate(parts[:-1]):
        child = _list_item(node, part, parts[: i + 1]) if isinstance(node, list) else node.get(part)
        if child is None:
            child = node[part] = {}
        if not isinstance(child, (dict, list)):
            raise InputError(".".join(parts[: i + 1]), "is not a mapping, cannot set a key below it")
        node = child
    if isinstance(node, list):
        _list_item(node, parts[-1], parts)
        node[int(parts[-1])] = value
    else:
        node[parts[-1]] = value


def _list_item(items: list, part: str, parts: list[str]):
    """The item `part` (a whole number below the length) of a list met on a path."""
    if not (part.isdigit() and int(part) < len(items)):
        raise InputError(".".join(parts), f"a list of {len(items)} items is indexed by 0 ... {len(items) - 1}")
    return items[int(part)]


_MISSING = object()


def field_value(scenario: Scenario, path: str, default=_MISSING):
    """The validated value of the field at dotted `path` (its default when the file left it out):
    `model.*` the system's parameters, `pipeline.SLOT.type` and `pipeline.SLOT.*` a stage's name
    and parameters, `reference.*` likewise, `initial.*`, `sim.*`, `checks.NAME.max|min`.
    An unknown path returns `default`, or raises KeyError without one."""
    parts = path.split(".")
    head, rest = parts[0], parts[1:]
    if head == "pipeline" and rest and rest[0] in scenario.stages:
        node, rest = _named(scenario.stages[rest[0]], rest[1:])
    elif head == "reference" and scenario.reference is not None:
        node, rest = _named(scenario.reference, rest)
    else:
        node = getattr(scenario, head, _MISSING) if head != "stages" else _MISSING
    for part in rest:
        if isinstance(node, dict):
            node = node.get(part, _MISSING)
        elif isinstance(node, list):
            node = node[int(part)] if part.isdigit() and int(part) < len(node) else _MISSING
        elif node is not _MISSING and part in getattr(node, "__dataclass_fields__", {}):
            node = getattr(node, part)
        else:
            node = _MISSING
    if node is _MISSING:
        if default is _MISSING:
            raise KeyError(path)
        return default
    return node


def _named(entry: tuple, rest: list[str]):
    """(node, rest of the path) inside a (name, params) pair: `type` is the name."""
    name, params = entry
    if rest[:1] == ["type"]:
        return name, rest[1:]
    return params, rest


def load_scenario(name_or_path: str, overrides: list[str] = ()) -> Scenario:
    return parse(*load_mapping(name_or_path, overrides))


def load_mapping(name_or_path: str, overrides: list[str] = ()) -> tuple[dict, str]:
    """The raw mapping of a scenario file (by path or name) with `overrides` applied, and its path."""
    path = resolve_path(name_or_path)
    data = read_yaml(path)
    for assignment in overrides:
        apply_override(data, assignment)
    return data, str(path)
