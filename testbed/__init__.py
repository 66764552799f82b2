"""Gyrodyne testbed: MuJoCo spacecraft attitude control with control-moment gyroscopes.

The public API (docs/api.md, "Python API"):

- `load(name_or_path, overrides)`, `run(scenario, out=None)`, `read(rrd)`: scenarios and runs;
  a run's `RunResult` carries status, metrics, checks and `trace[key] -> (t, values)`.
- `stage(slot, name, Params)` registers a stage; `Sensor`, `Estimator`, `Law`, `Allocator`
  state the four slots' interfaces; `StageContext` is what a stage may know when built.
- `system`, `metric`, `reference`: the other registries (a metric gets the run's `RunData`); `param`: a schema field with its
  bounds; `Plant`: the base of a system's plant; `InputError`: bad input, naming the field.
"""

from testbed.api import load, read, run
from testbed.errors import InputError
from testbed.metrics import metric
from testbed.pipeline import Allocator, Estimator, Law, Sensor, StageContext, StageInfo, stage
from testbed.plant import Plant
from testbed.references.registry import reference
from testbed.runner import RunData, RunResult
from testbed.scenario.schema import param
from testbed.systems.registry import system

__version__ = "0.1.0"

__all__ = ["Allocator", "Estimator", "InputError", "Law", "Plant", "RunData", "RunResult", "Sensor", "StageContext",
           "StageInfo", "load", "metric", "param", "read", "reference", "run", "stage", "system"]
