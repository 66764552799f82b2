"""Gyrodyne testbed: MuJoCo spacecraft attitude control with control-moment gyroscopes.

The public API (docs/api.md, "Python API"):

- `load(name_or_path, overrides)`, `run(scenario, out=None)`, `read(rrd)`: scenarios and runs;
  a run's `RunResult` carries status, metrics, checks and `trace[key] -> (t, values)`.
- `stage(slot, name, Params)` registers a stage; `Sensor`, `Estimator`, `Law`, `Allocator`
  state the four slots' interfaces; `StageContext` is what a stage may know when built.
- `system`, `metric`, `reference`: the other registries (a metric gets the run's `RunData`); `param`: a schema field with its
  bounds; `Plant`: the base of a system's plant; `InputError`: bad input, naming the field.
- `Simulation(scenario)`: a run stepped a control period at a time (`reset(seed)`, `step()`,
  `close()`; docs/stepping.md); `run(scenario, stages={"law": obj})` takes Python objects as
  stages. The Gymnasium environments are in `testbed.gym` (import it to register them).

Each name is imported when first used (PEP 562), so that `import testbed.cli` is quick and a
Ctrl-C while MuJoCo, SciPy and Dask load reaches the command line's own handling.
"""

import importlib

__version__ = "0.1.0"

_SOURCES = {
    "load": "testbed.api", "read": "testbed.api", "run": "testbed.api",
    "InputError": "testbed.errors",
    "metric": "testbed.metrics",
    "Allocator": "testbed.run_core.stage_contract", "Estimator": "testbed.run_core.stage_contract",
    "Law": "testbed.run_core.stage_contract", "Sensor": "testbed.run_core.stage_contract",
    "StageContext": "testbed.run_core.stage_contract", "StageInfo": "testbed.run_core.stage_contract",
    "stage": "testbed.run_core.stage_registry",
    "Plant": "testbed.plant",
    "reference": "testbed.references.registry",
    "RunData": "testbed.run_core.result", "RunResult": "testbed.run_core.result",
    "param": "testbed.scenario.schema",
    "Simulation": "testbed.stepping.simulation",
    "system": "testbed.systems.registry",
}

__all__ = sorted(_SOURCES)


def __getattr__(name: str):
    if name not in _SOURCES:
        raise AttributeError(f"module 'testbed' has no attribute {name!r}")
    value = getattr(importlib.import_module(_SOURCES[name]), name)
    globals()[name] = value  # once: later lookups do not come here
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_SOURCES))
