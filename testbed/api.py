"""The testbed's Python API (`import testbed`): load a scenario, run it, read a run back.

    scenario = testbed.load("reorient_minimax", ["pipeline.allocator.beta_rate_max_deg_s=4"])
    result = testbed.run(scenario, out="runs/x.rrd")     # out=None: no file
    result = testbed.run(scenario, stages={"law": my_law})  # a Python object as the law
    result.status, result.passed, result.metrics["final_attitude_error_deg"]
    t, omega = result.trace["truth/omega"]               # (N,), (N, 3) [s], [rad/s]
    again = testbed.read("runs/x.rrd")                   # the same structure, from the file

Bad input raises `testbed.InputError` (its `field` names the scenario key); a run that
diverges, whose method leaves its validity or whose stage fails returns status "diverged",
"method_failed" or "error" with the trace so far.
The command line (`testbed run | check | inspect`) is built on these functions.
"""

from __future__ import annotations

import os
from pathlib import Path

from testbed.errors import InputError
from testbed.math.validation import existing_file
from testbed.run_core.in_progress import run_scenario
from testbed.run_core.result import STATUSES, RunResult
from testbed.scenario.loading import Scenario, load_scenario, parse
from testbed.scenario.yaml_reading import as_loaded
from testbed.recording.output_paths import CheckedPath, output_path
from testbed.recording.trace_reader import read_rrd


def load(name_or_path: str | Path, overrides: list[str] = ()) -> Scenario:
    """A validated scenario: a file path or a name from the shipped scenarios, with
    `key.path=value` overrides applied first (validated exactly like the file)."""
    if isinstance(overrides, (str, bytes)) or not isinstance(overrides, (list, tuple)):
        raise InputError("overrides", f"must be a list of key.path=value strings, got {type(overrides).__name__}")
    return load_scenario(str(name_or_path), list(overrides))


def run(scenario: Scenario | str | Path | dict, out: str | Path | None = None,
        overrides: list[str] = (), progress=None, *, keep_trace: bool = True, live=None,
        prepared=None, stages: dict | None = None) -> RunResult:
    """Run a scenario (a `Scenario`, a name or path, or a raw mapping as a YAML file holds it:
    strings such as '1e-4' that the project's loader reads as numbers are numbers here too) and
    return its result with the whole trace; `out` (a path) also writes the `.rrd` there, checked
    before the run (testbed.recording.output_paths). `keep_trace=False` keeps only what the
    metrics need (memory flat however long the run); `live`: a viewer stream the run is also
    sent to (testbed.recording.live_view.ViewerStream); `prepared`: the run's plan
    (`testbed.run_core.plan.prepare(scenario)`), if it was made to check the scenario before this
    run. `stages`: slot -> a Python object that takes that slot's place, with no registration
    (`{"law": my_law}`: an object with the slot's method, e.g. `torque(t, estimate)`, or a function
    called as it), held to a plug-in's output checks (docs/stepping.md)."""
    if out is not None and not isinstance(out, (str, os.PathLike)):
        raise InputError("out", f"must be a file path (str or pathlib.Path) or None, got {type(out).__name__}")
    if progress is not None and not callable(progress):
        raise InputError("progress", f"must be a function of the fraction done, or None, got {type(progress).__name__}")
    if isinstance(scenario, dict):
        if overrides:
            raise InputError("overrides", "apply overrides to the mapping itself")
        scenario = parse(as_loaded(scenario))  # validated as the same mapping read from a file
    elif not isinstance(scenario, Scenario):
        scenario = load(scenario, overrides)
    elif overrides:
        raise InputError("overrides", "a loaded Scenario is already validated: pass overrides to load()")
    if isinstance(out, CheckedPath):  # checked once already, by the command line
        out = out.path
    elif out is not None:
        out = output_path(out)  # as given: a trailing "/" matters
    return run_scenario(scenario, out, progress, keep_data=keep_trace,
                        live=live, prepared=prepared, stages=stages)


def read(path: str | Path) -> RunResult:
    """A run read back from its `.rrd`: the stored result (status, metrics, checks) and every
    recorded signal as arrays. A file that is not a testbed run raises InputError."""
    info = _read_checked(path, signals=True)
    fields = ("scenario", "sim_s", "wall_s", "status", "error", "metrics", "checks")
    return RunResult(*(info["result"][k] for k in fields), rrd=str(path), trace=info["trace"])


def inspect(path: str | Path) -> dict:
    """What `testbed inspect` shows of an `.rrd`, read in one pass: its entities and their row
    counts, time span, stored result, and whether the run finished (testbed.recording.trace_reader
    `read_rrd`). A file that is not a testbed run raises InputError."""
    return _read_checked(path, signals=False)


def _read_checked(path: str | Path, signals: bool) -> dict:
    if not existing_file("rrd", path):
        raise InputError("rrd", f"no such file: {path}")
    path = Path(path)
    try:
        info = read_rrd(path, signals=signals)
    except Exception as exc:  # a foreign or damaged file is bad input, not a crash
        raise InputError("rrd", f"cannot read {path}: {exc}") from None
    if not _is_result(info["result"]):
        raise InputError("rrd", f"{path}: its run/result entity is not a testbed result")
    return info


def _is_result(stored) -> bool:
    """The shape `RunResult.as_json` writes: names, numbers and checks of the right types."""
    def number(x):
        return isinstance(x, (int, float)) and not isinstance(x, bool)

    def check(c):
        return (isinstance(c, dict) and isinstance(c.get("name"), str) and isinstance(c.get("limit"), str)
                and isinstance(c.get("passed"), bool) and (number(c.get("value")) or c.get("value") is None))

    return (isinstance(stored, dict) and isinstance(stored.get("scenario"), str)
            and number(stored.get("sim_s")) and number(stored.get("wall_s"))
            and stored.get("status") in STATUSES
            and (stored.get("error") is None or isinstance(stored.get("error"), str))
            and isinstance(stored.get("metrics"), dict)
            and all(isinstance(k, str) and (number(v) or v is None) for k, v in stored["metrics"].items())
            and isinstance(stored.get("checks"), list) and all(check(c) for c in stored["checks"]))
