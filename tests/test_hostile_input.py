"""Hostile and mistaken input against the command line's exit-status contract (README "Exit status"):

- 0: every check passed;
- 1: a check failed, the run diverged (status "diverged") or a stage failed at run time
  (status "error"); the trace up to that point is written and `testbed inspect` reads it;
- 2: bad input: exactly ONE line on stderr, "error: <field>: <reason>", no traceback, and no
  file written (no .rrd, no *.partial, nothing else left in the --out folder or the cwd);
- 130: Ctrl-C (SIGINT), 143: SIGTERM, with no partial file left.

Error messages quote at most ~80 characters of an offending value.

Most tests call `testbed.cli.main` in-process from an empty working directory (tmp_path/cwd)
and capture stdout/stderr at the file-descriptor level (capfd), so that anything MuJoCo or
Rerun writes from C or Rust is seen too. Signals, hangs and concurrent runs need a real
process (`python -m testbed`).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

import testbed
import testbed.scenario.loading
import testbed.scenario.shipped_files
from testbed.cli import main
from testbed.errors import InputError
from testbed.scenario.shipped_files import SCENARIO_DIR

# Keeps shipped scenarios short where only the handling of the input matters.
SHORT = "sim.duration_s=0.5"
NO_CHECKS = "checks={}"


# --- helpers --------------------------------------------------------------------------------

@dataclass
class Outcome:
    code: int
    out: str
    err: str
    cwd: Path

    @property
    def lines(self) -> list[str]:
        return self.err.splitlines()


@pytest.fixture
def cli(tmp_path, monkeypatch, capfd):
    """main(argv) run from an empty cwd (tmp_path/cwd); returns an Outcome."""
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    monkeypatch.chdir(cwd)
    capfd.readouterr()

    def call(*argv) -> Outcome:
        code = main([str(a) for a in argv])
        out, err = capfd.readouterr()
        return Outcome(code, out, err, cwd)

    return call


@pytest.fixture
def inputs(tmp_path) -> Path:
    """A folder for input files, outside the cwd (which must stay empty on exit 2)."""
    folder = tmp_path / "in"
    folder.mkdir()
    return folder


def everything_in(folder: Path) -> list[str]:
    """Every file, directory and link below `folder` (hidden ones included), relative."""
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def assert_refused(result: Outcome, field: str | None = None, *words: str, folder: Path | None = None) -> str:
    """Exit 2, exactly one stderr line `error: <field>: <reason>` containing `words`, no
    traceback, nothing on stdout and nothing written to the cwd (or `folder`)."""
    assert "Traceback" not in result.err, result.err
    assert result.code == 2, (result.code, result.out[-2000:], result.err[-2000:])
    assert len(result.lines) == 1, result.err
    line = result.lines[0]
    prefixes = ("error: ",) if field is None else (f"error: {field}: ", f"error: {field}[")  # or an item of it
    assert line.startswith(prefixes), line
    for word in words:
        assert word in line, line
    assert result.out == "", result.out
    for place in (result.cwd, folder):
        if place is not None:
            assert everything_in(place) == [], f"exit 2 left files behind in {place}: {everything_in(place)}"
    return line


def assert_ran(result: Outcome, out: Path, codes=(0, 1)) -> dict:
    """Exit 0 or 1 (as allowed), no traceback, the trace written and readable: its stored result."""
    assert "Traceback" not in result.err, result.err
    assert result.code in codes, (result.code, result.out[-2000:], result.err[-2000:])
    assert out.is_file(), f"no trace at {out}"
    assert not list(out.parent.glob("*.partial")), list(out.parent.iterdir())
    return testbed.read(out).as_json()


def read_yaml_of(path: Path) -> dict:
    from testbed.scenario.yaml_reading import read_yaml

    return read_yaml(path)


def shipped(name: str) -> dict:
    """A shipped scenario's mapping, read as testbed reads it (`1e-9` is a number)."""
    return read_yaml_of(SCENARIO_DIR / f"{name}.yaml")


def write_yaml(folder: Path, name: str, data) -> Path:
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def run_subprocess(argv, cwd: Path, timeout: float = 60, **popen):
    """`python -m testbed argv` in `cwd`; (exit status, stdout, stderr)."""
    proc = subprocess.run([sys.executable, "-m", "testbed", *map(str, argv)], cwd=cwd, capture_output=True,
                          text=True, timeout=timeout, **popen)
    return proc.returncode, proc.stdout, proc.stderr


def argv_id(argv) -> str:
    """A readable test id for an argv: each argument cut to 24 characters."""
    return " ".join(a if len(a) <= 24 else f"{a[:12]}...({len(a)})" for a in map(str, argv)).replace("\0", "NUL")


# --- 1. wrong types where a mapping or a name is expected ------------------------------------

@pytest.mark.parametrize("value", ["'ideal_torque'", "[gimbal_rate_profile]", "3", "true", "[]"])
def test_pipeline_slot_that_is_not_a_mapping(cli, value):
    result = cli("run", "cmg_open_loop", "--out", "x.rrd", "--set", f"pipeline.allocator={value}")
    assert_refused(result, "pipeline.allocator", "mapping")


@pytest.mark.parametrize("path", ["model.system", "pipeline.allocator.type", "reference.type",
                                  "pipeline.sensor.type", "pipeline.law.type"])
@pytest.mark.parametrize("value", ["[cmg_rhombus]", "{name: cmg_rhombus}", "[[1, 2], {a: b}]", "{}", "[]"])
def test_name_given_as_a_list_or_mapping(cli, path, value):
    result = cli("run", "cmg_open_loop", "--out", "x.rrd", "--set", f"{path}={value}")
    assert_refused(result, path)


def test_model_that_is_not_a_mapping(cli):
    assert_refused(cli("run", "cmg_open_loop", "--out", "x.rrd", "--set", "model=[cmg_rhombus]"), "model")


# --- 2. files that are not UTF-8 YAML --------------------------------------------------------

LATIN1 = "name: caf\xe9\ndescription: d\xe9j\xe0 vu\nmodel: {system: satellite}\nsim: {duration_s: 1}\n".encode("latin-1")


def test_scenario_file_that_is_not_utf8(cli, inputs):
    path = inputs / "latin1.yaml"
    path.write_bytes(LATIN1)
    assert_refused(cli("run", path, "--out", "x.rrd"), str(path), "UTF-8")


def test_list_survives_a_non_utf8_file_in_the_scenario_folder(cli, tmp_path, monkeypatch):
    folder = tmp_path / "scenarios"
    shutil.copytree(SCENARIO_DIR, folder)
    (folder / "latin1.yaml").write_bytes(LATIN1)
    (folder / "random_bytes.yaml").write_bytes(bytes(range(256)) * 4)
    monkeypatch.setattr(testbed.scenario.shipped_files, "SCENARIO_DIR", folder)
    monkeypatch.setattr(testbed.scenario.loading, "SCENARIO_DIR", folder)
    result = cli("list")
    assert result.code == 0, result.err
    assert result.err == ""
    lines = result.out.splitlines()
    assert len(lines) == len(list(folder.glob("*.yaml")))
    bad = [line for line in lines if line.startswith(("latin1 ", "random_bytes "))]
    assert len(bad) == 2 and all("cannot be read" in line and "UTF-8" in line for line in bad), bad
    assert any(line.startswith("cmg_open_loop ") for line in lines)
    # and by name, through the same folder, it is refused like any bad file
    assert_refused(cli("run", "latin1", "--out", "x.rrd"), str(folder / "latin1.yaml"), "UTF-8")


def test_huge_scenario_file_is_refused_without_reading_it(cli, inputs, monkeypatch):
    """A 512 MB (sparse) file: refused by its size, never opened (a read would load it into memory)."""
    path = inputs / "huge.yaml"
    with open(path, "wb") as handle:
        handle.truncate(512 * 2**20)
    opened, path_open = [], Path.open

    def spied_open(self, *args, **kwargs):
        opened.append(Path(self).name)
        return path_open(self, *args, **kwargs)

    monkeypatch.setattr(Path, "open", spied_open)
    result = cli("run", path, "--out", "x.rrd")
    assert_refused(result, str(path), "bytes")
    assert "huge.yaml" not in opened, "the file was opened before its size was checked"


# --- 3. deep nesting, alias bombs, duplicate keys --------------------------------------------

def test_ten_thousand_deep_nested_list_in_a_file(cli, inputs):
    path = inputs / "deep.yaml"
    path.write_text("name: deep\nmodel: {system: satellite}\nsim: {duration_s: 1}\n"
                    "description: " + "[" * 10_000 + "]" * 10_000 + "\n")
    assert_refused(cli("run", path, "--out", "x.rrd"), str(path), "nested")


def test_ten_thousand_deep_nested_list_in_a_set_value(cli):
    result = cli("run", "cmg_open_loop", "--out", "x.rrd", "--set", "description=" + "[" * 10_000 + "]" * 10_000)
    assert_refused(result, "--set description", "nested")


BILLION_LAUGHS = """\
name: bomb
model: {system: satellite}
sim: {duration_s: 1}
a: &a ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]
b: &b [*a, *a, *a, *a, *a, *a, *a, *a, *a]
c: &c [*b, *b, *b, *b, *b, *b, *b, *b, *b]
d: &d [*c, *c, *c, *c, *c, *c, *c, *c, *c]
e: &e [*d, *d, *d, *d, *d, *d, *d, *d, *d]
f: &f [*e, *e, *e, *e, *e, *e, *e, *e, *e]
g: &g [*f, *f, *f, *f, *f, *f, *f, *f, *f]
h: &h [*g, *g, *g, *g, *g, *g, *g, *g, *g]
i: &i [*h, *h, *h, *h, *h, *h, *h, *h, *h]
{field}: *i
"""


@pytest.mark.parametrize("field", ["description", "name"])
def test_alias_bomb_in_a_string_field_is_refused_quickly(cli, inputs, field):
    path = inputs / "bomb.yaml"
    path.write_text(BILLION_LAUGHS.replace("{field}", field))
    result = cli("run", path, "--out", "x.rrd")
    line = assert_refused(result, str(path), "alias")
    assert len(line) < 200 + len(str(path))


def test_alias_bomb_in_a_set_value_is_refused(cli):
    result = cli("run", "cmg_open_loop", "--out", "x.rrd", "--set",
                 "description=[&a [lol, lol, lol], &b [*a, *a, *a], [*b, *b, *b]]")
    assert_refused(result, "--set description", "alias")


@pytest.mark.parametrize("text, word", [
    ("name: dup\nmodel: {system: satellite}\nsim: {duration_s: 1}\nsim: {duration_s: 2}\n", "'sim' is given twice"),
    ("name: dup\nmodel: {system: satellite, system: gyrostat}\nsim: {duration_s: 1}\n", "'system' is given twice"),
    ("name: dup\nmodel: {system: satellite}\nsim:\n  duration_s: 1\n  duration_s: 1\n", "'duration_s' is given twice"),
])
def test_duplicate_key(cli, inputs, text, word):
    path = inputs / "dup.yaml"
    path.write_text(text)
    assert_refused(cli("run", path, "--out", "x.rrd"), str(path), word)


def test_duplicate_key_in_a_set_value(cli):
    result = cli("run", "cmg_open_loop", "--out", "x.rrd", "--set", "initial={quat: [1, 0, 0, 0], quat: [0, 1, 0, 0]}")
    assert_refused(result, "--set initial", "given twice")


# --- 4. resources: durations, steps, trace samples, sweep sizes -------------------------------

@pytest.mark.parametrize("overrides, fields_named", [
    (["sim.duration_s=1e12"], ("sim.duration_s",)),
    (["sim.dt_s=1e-12"], ("sim.duration_s", "sim.dt_s")),
    (["sim.duration_s=1e308"], ("sim.duration_s",)),
    (["sim.duration_s=100000000000000000000000000000"], ("sim.duration_s",)),
    (["sim.duration_s=1e7", "sim.dt_s=0.01", "sim.control_period_s=0.01"], ("sim.trace_period_s", "sim.duration_s")),
    # a control or trace period so large that period / dt overflows a float
    (["sim.control_period_s=1e308"], ("sim.control_period_s", "sim.duration_s")),
    (["sim.trace_period_s=1e308"], ("sim.trace_period_s", "sim.duration_s")),
])
def test_resource_limits_are_refused_before_the_run(cli, overrides, fields_named):
    argv = ["run", "cmg_open_loop", "--out", "x.rrd"]
    for assignment in overrides:
        argv += ["--set", assignment]
    result = cli(*argv)
    line = assert_refused(result)
    assert line.split(": ")[1] in fields_named, line


@pytest.mark.parametrize("overrides", [
    ["sim.duration_s=1e12", "sim.trace_period_s=1e9"],
    ["sim.duration_s=1e12", "sim.dt_s=1", "sim.control_period_s=1", "sim.trace_period_s=1e6"],
])
def test_huge_duration_with_a_large_trace_period_is_refused_at_once(tmp_path, overrides):
    argv = ["run", "cmg_open_loop", "--out", tmp_path / "x.rrd"]
    for assignment in overrides:
        argv += ["--set", assignment]
    code, out, err = run_subprocess(argv, tmp_path, timeout=90)  # a hang guard: 3x the 20.2 s measured under load
    assert "Traceback" not in err
    assert code == 2 and len(err.splitlines()) == 1 and err.startswith("error: sim."), err
    assert everything_in(tmp_path) == []


HUGE_INT = 10**400


@pytest.mark.parametrize("path, value", [("sim.duration_s", f"{HUGE_INT}"), ("model.mass_kg", f"{HUGE_INT}"),
                                         ("sim.dt_s", f"{HUGE_INT}"), ("initial.quat", f"[{HUGE_INT}, 0, 0, 0]"),
                                         ("model.inertia_kg_m2", f"[{HUGE_INT}, 1000, 1200]")])
def test_integer_beyond_the_float_range(cli, path, value):
    """A 401-digit integer where a number is expected: bad input, not an OverflowError."""
    result = cli("run", "cmg_open_loop", "--out", "x.rrd", "--set", f"{path}={value}")
    line = assert_refused(result)
    assert line.startswith(f"error: {path}"), line
    assert "0" * 100 not in line


@pytest.mark.parametrize("sweep", [
    "{random: {pipeline.law.beta22: {uniform: [0, 8]}}, samples: 1000000000}",
    "{grid: {pipeline.law.beta11: [1, 4]}, random: {pipeline.law.beta22: {uniform: [0, 8]}}, samples: 100000}",
    "{grid: {pipeline.law.beta11: %s, pipeline.law.k: %s, pipeline.law.beta22: %s}}" % ((list(range(1, 101)),) * 3),
])
def test_huge_sweep_is_refused_before_anything_runs(cli, sweep):
    result = cli("sweep", "akor_sweep", "--out", "sweep_out", "--workers", "1", "--set", f"sweep={sweep}")
    assert_refused(result, "sweep", "cases")


@pytest.mark.parametrize("distribution", ["{uniform: [-1e308, 1e308]}", "{log_uniform: [1e-300, 1e308]}",
                                          "{uniform: [0, 1e308]}", "{integer: [0, 9223372036854775807]}"])
def test_sweep_distribution_spanning_the_float_range(cli, distribution):
    """Draws from [-1e308, 1e308] (high - low overflows): refused naming the sweep field, not
    numpy's OverflowError; nothing runs."""
    result = cli("sweep", "akor_sweep", "--out", "sweep_out", "--workers", "1",
                 "--set", f"sweep={{random: {{pipeline.law.beta22: {distribution}}}, samples: 2}}")
    assert_refused(result, None, "sweep")


@pytest.mark.parametrize("duration, trace_period", [("10", "3"), ("20", "1000")])
def test_trace_period_that_does_not_divide_the_run(cli, duration, trace_period):
    """A trace period that does not divide the duration (or exceeds it): refused naming
    sim.trace_period_s, or the run is whole: docs/api.md "the final state, at duration_s, is recorded
    for truth/*", so the trace and sim_s reach duration_s (and final_* metrics are final)."""
    out = Path.cwd() / "x.rrd"
    result = cli("run", "torque_free_skylab", "--out", out, "--json", "--set", f"sim.duration_s={duration}",
                 "--set", f"sim.trace_period_s={trace_period}")
    if result.code == 2:
        assert_refused(result, "sim.trace_period_s")
        return
    stored = assert_ran(result, out)
    t, _ = testbed.read(out).trace["truth/omega"]
    assert t[-1] == pytest.approx(float(duration)), t
    assert stored["sim_s"] == pytest.approx(float(duration))


# --- 5. vectors of the wrong length for the system --------------------------------------------

def test_three_gimbal_profile_on_the_four_gimbal_cluster(cli):
    result = cli("run", "cmg_open_loop", "--out", "x.rrd",
                 "--set", "pipeline.allocator.offset=[0, 0, 0]",
                 "--set", "pipeline.allocator.amplitude_deg_s=[3, 2, 4]",
                 "--set", "pipeline.allocator.frequency_hz=[0.02, 0.031, 0.013]",
                 "--set", "pipeline.allocator.phase_deg=[0, 60, 135]")
    assert_refused(result, "pipeline.allocator.offset", "4 gimbals")


def test_three_gimbal_profile_with_the_default_output_leaves_no_runs_folder(cli):
    """The same refusal without --out: nothing may appear in the cwd, not even an empty runs/."""
    result = cli("run", "cmg_open_loop",
                 "--set", "pipeline.allocator.offset=[0, 0, 0]",
                 "--set", "pipeline.allocator.amplitude_deg_s=[3, 2, 4]",
                 "--set", "pipeline.allocator.frequency_hz=[0.02, 0.031, 0.013]",
                 "--set", "pipeline.allocator.phase_deg=[0, 60, 135]")
    assert_refused(result, "pipeline.allocator.offset")


@pytest.mark.parametrize("key, value", [
    ("amplitude_deg_s", "[1, 2, 3]"),
    ("amplitude_deg_s", "[1, 2, 3, 4, 5]"),
    ("frequency_hz", "[]"),
])
def test_profile_vectors_of_unequal_length(cli, key, value):
    assert_refused(cli("run", "cmg_open_loop", "--out", "x.rrd", "--set", f"pipeline.allocator.{key}={value}"),
                   None, "pipeline.allocator")


@pytest.mark.parametrize("path, value", [
    ("model.inertia_kg_m2", "[800, 1000]"),
    ("model.gimbal_angles_deg", "[30, -60, -20]"),
    ("initial.omega_deg_s", "[0.2, -0.1]"),
    ("initial.quat", "[1, 0, 0]"),
])
def test_model_and_initial_vectors_of_the_wrong_length(cli, path, value):
    assert_refused(cli("run", "cmg_open_loop", "--out", "x.rrd", "--set", f"{path}={value}"), path)


# --- 6. masses and inertias of 1e-300 and 1e308 -----------------------------------------------

def _mass_property_cases():
    """(scenario, model field, YAML value) for every mass or inertia field of every system."""
    from testbed.plugins import discover
    from testbed.systems.registry import SYSTEMS

    discover()
    one_per_system = {}
    for path in sorted(SCENARIO_DIR.glob("*.yaml")):
        data = read_yaml_of(path)
        if "sweep" not in data:
            one_per_system.setdefault(data["model"]["system"], (path.stem, data))
    cases = []
    for system, (scenario, data) in sorted(one_per_system.items()):
        params = SYSTEMS[system].params
        for f in fields(params):
            if "mass" not in f.name and "inertia" not in f.name:
                continue
            current = data["model"].get(f.name)
            if current is None:
                current = f.default_factory() if callable(f.default_factory) else f.default
            for tiny_or_huge in (1e-300, 1e308):
                if isinstance(current, list) and current and isinstance(current[0], list):
                    value = [[tiny_or_huge if i == j else 0.0 for j in range(3)] for i in range(3)]
                elif isinstance(current, list):
                    value = [tiny_or_huge] * len(current)
                else:
                    value = tiny_or_huge
                cases.append(pytest.param(scenario, f.name, value, id=f"{system}-{f.name}-{tiny_or_huge:g}"))
    # the same fields under the scenarios whose stages read the inertia before the run
    for scenario in ("reorient_minimax", "lebedev_spinup_cmg"):
        for key in ("rotor_mass_kg", "gimbal_mass_kg"):
            cases.append(pytest.param(scenario, key, 1e308, id=f"{scenario}-{key}-1e+308"))
    return cases


def _short_run(name: str) -> list[str]:
    """--set arguments that make shipped scenario `name` run for a few control periods, no checks."""
    sim = shipped(name)["sim"]
    period = sim.get("trace_period_s") or sim.get("control_period_s") or sim.get("dt_s", 0.002)
    return ["--set", f"sim.duration_s={4 * period!r}", "--set", NO_CHECKS]


@pytest.mark.parametrize("scenario, key, value", _mass_property_cases())
def test_extreme_mass_or_inertia_is_refused_naming_the_field(cli, scenario, key, value):
    """Exit 2 naming the field: `model.<key>`, or a sibling `model.` field when a relation between
    the two is what fails (a rotor's Js <= 2 Jt); never the bare `model` of a MuJoCo compiler
    error, a pipeline field, or NaN/inf computed from the value."""
    result = cli("run", scenario, "--out", "x.rrd", "--set", f"model.{key}={value!r}", *_short_run(scenario))
    line = assert_refused(result, None, "model.")
    field = line.split(": ")[1]
    if field != f"model.{key}":
        assert field.startswith("model.") and not any(junk in line for junk in ("nan", "inf", "np.float64")), line


# --- 6b. stage parameters that make the design or the run itself blow up ------------------------

class _Hang(BaseException):
    pass


def _watchdog(seconds: float):
    """Context: raise _Hang in this (main) thread after `seconds` (an input that must be refused at
    once must not make the test wait for ever)."""
    import contextlib

    @contextlib.contextmanager
    def guard():
        def on_alarm(signum, frame):
            raise _Hang(f"still running after {seconds} s: the input was neither refused nor run quickly")

        previous = signal.signal(signal.SIGALRM, on_alarm)
        signal.setitimer(signal.ITIMER_REAL, seconds)
        try:
            yield
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)

    return guard()


@pytest.mark.parametrize("assignment", ["pipeline.law.beta22=1e100", "pipeline.law.k=1e-300",
                                        "pipeline.law.k=1e300", "pipeline.law.beta11=1e-300"])
def test_lqr_weights_the_riccati_solver_cannot_handle(cli, assignment):
    """akor_lqr's Riccati equation without a finite solution: bad input naming the law's
    parameters (or a run that fails), never scipy's LinAlgError."""
    out = Path.cwd() / "x.rrd"
    result = cli("run", "planar_akor", "--out", out, "--set", assignment, "--set", NO_CHECKS,
                 "--set", "sim.duration_s=0.06")
    assert "Traceback" not in result.err
    if result.code == 2:
        assert_refused(result, None, "pipeline.law")
    else:
        assert_ran(result, out)


@pytest.mark.parametrize("scenario, assignment, field", [
    ("reorient_minimax", "pipeline.law.duration_s=1e308", None),
    ("reorient_minimax", "pipeline.law.natural_frequency_rad_s=1e308", None),
    ("reorient_minimax", "pipeline.law.damping_ratio=1e308", None),
    ("reorient_minimax", "pipeline.allocator.beta_rate_max_deg_s=1e308", None),
    ("cmg_open_loop", "model.rotor_speed_rpm=5e-324", "model.rotor_speed_rpm"),
    ("cmg_open_loop", "model.rotor_momentum_nms=1e308", None),
    ("gyrostat_program", "pipeline.law.stiffness_nm_rad=[[1e308, 0, 0], [0, 1e308, 0], [0, 0, 1e308]]", None),
    # not positive definite: refused like [[-1, 0, 0], ...] is
    ("gyrostat_program", "pipeline.law.damping_nms_rad=[[-1e308, 0, 0], [0, 500, 0], [0, 0, 500]]",
     "pipeline.law.damping_nms_rad"),
    ("gyrostat_program", "pipeline.law.stiffness_nm_rad=[[-1e308, 0, 0], [0, 100, 0], [0, 0, 100]]",
     "pipeline.law.stiffness_nm_rad"),
])
def test_parameters_at_the_ends_of_the_float_range(cli, scenario, assignment, field):
    """Stage and model parameters near 1e308 or 5e-324: refused (exit 2, naming `field` where it
    is given), or a run that ends with exit 1 and a trace; never an OverflowError,
    ZeroDivisionError or LinAlgError traceback."""
    sim = shipped(scenario)["sim"]
    period = sim.get("trace_period_s") or sim.get("control_period_s") or sim.get("dt_s", 0.002)
    out = Path.cwd() / "x.rrd"
    result = cli("run", scenario, "--out", out, "--set", assignment, "--set", NO_CHECKS,
                 "--set", f"sim.duration_s={6 * period!r}")
    assert "Traceback" not in result.err
    if field is not None or result.code == 2:
        assert_refused(result, field)
    else:
        assert_ran(result, out)


@pytest.mark.parametrize("substep", ["1e-300", "1e-12"])
def test_observer_substep_so_small_the_run_never_ends(cli, substep):
    """The Lebedev observer integrates each control period in substeps of max_substep_s: 1e-300 s
    means ~1e298 RK4 steps per tick. That must be refused at once (like dt_s), not run for ever."""
    with _watchdog(5.0):
        result = cli("run", "lebedev_detumble_ideal", "--out", "x.rrd", "--set", "sim.duration_s=5",
                     "--set", f"pipeline.estimator.max_substep_s={substep}")
    assert_refused(result, "pipeline.estimator.max_substep_s")


@pytest.mark.parametrize("poles, pole", [("[-1e90, -1, -1]", "-1e+90"), ("[-0.1, -45, -0.1]", "-45")])
def test_observer_poles_the_rk4_substeps_cannot_integrate(cli, poles, pole):
    """The paper example integrates its observer in RK4 substeps of h = 0.0625 s; a mode at p is
    damped only while |R(p h)| < 1 (R = 1 + z + z^2/2 + z^3/6 + z^4/24: |p| h < 2.785 on the real
    axis, so -44 1/s is and -45 1/s is not). Refused before the run, not an overflow at t = 0.0625 s."""
    line = assert_refused(cli("run", "lebedev_spinup_ideal", "--out", "x.rrd", "--set", f"pipeline.estimator.poles_per_s={poles}"),
                          "pipeline.estimator.poles_per_s", f"pole {pole} 1/s", "0.0625 s")
    assert "Traceback" not in line


def test_observer_pole_inside_the_rk4_region_runs(cli):
    """-44 1/s at h = 0.0625 s (z = -2.75, |R| = 0.95): accepted and run."""
    out = Path.cwd() / "x.rrd"
    assert_ran(cli("run", "lebedev_spinup_ideal", "--out", out, "--set", "pipeline.estimator.poles_per_s=[-0.1, -44, -0.1]",
                   "--set", NO_CHECKS, "--set", "sim.duration_s=1"), out)


def test_stored_momentum_spin_up_without_start_up_phase(cli):
    """startup_s 0 with measured momentum: the load-time checks take L where it starts (the idle
    start-up that turns it lasts no time; solve_ivp was handed an empty span and raised)."""
    out = Path.cwd() / "x.rrd"
    assert_ran(cli("run", "lebedev_spinup_cmg_momentum", "--out", out, "--set", "pipeline.estimator.startup_s=0",
                   "--set", NO_CHECKS, "--set", "sim.duration_s=2"), out)


# (1e308 before every number was held within 1e100: scenario/schema.py)
@pytest.mark.parametrize("assignment", ["pipeline.estimator.startup_s=1e100", "pipeline.estimator.startup_s=1e7",
                                        "pipeline.allocator.beta_rate_max_deg_s=1e100"])
def test_stored_momentum_checks_at_the_ends_of_the_float_range(cli, assignment):
    """The stored-momentum load checks: a start-up longer than the run has no end spin to check
    (1e308 s asked numpy for an array of 1e308 samples, a traceback; 1e7 s solved the idle motion
    for minutes), and a gimbal-rate limit of 1e308 deg/s makes the torque shares 0 (an underflow
    was refused as 'cannot be built'). Both run."""
    out = Path.cwd() / "x.rrd"
    with _watchdog(60.0):
        assert_ran(cli("run", "lebedev_spinup_cmg_momentum", "--out", out, "--set", assignment,
                       "--set", NO_CHECKS, "--set", "sim.duration_s=1"), out)


@pytest.mark.parametrize("angle", ["1e100", "-361", "1e6"])
def test_gimbal_angle_beyond_a_turn(cli, angle):
    """A gimbal angle of 1e308 deg ran until MuJoCo called the first step diverged (exit 1, a
    trace); any angle beyond a turn is refused naming the gimbal, before the run."""
    assert_refused(cli("run", "cmg_open_loop", "--out", "x.rrd", "--set", f"model.gimbal_angles_deg=[30, {angle}, -20, 70]"),
                   "model.gimbal_angles_deg[1]", "more than a turn")


# --- 7. output paths, sweep folders, envelope size, inspect on things that are not runs ---------

def test_out_is_a_directory(cli):
    folder = Path.cwd() / "d"
    folder.mkdir()
    result = cli("run", "cmg_open_loop", "--out", folder, "--set", SHORT)
    assert result.code == 2 and result.lines[0].startswith("error: --out: ")
    assert everything_in(result.cwd) == ["d"]


def test_out_with_a_trailing_slash_is_a_directory_even_if_it_does_not_exist(cli):
    result = cli("run", "cmg_open_loop", "--out", str(Path.cwd() / "newdir") + os.sep, "--set", SHORT, "--set", NO_CHECKS)
    assert_refused(result, "--out", "directory")


def test_empty_names_are_refused_not_taken_as_the_current_folder(cli):
    """Path("") is "."; an empty --out or inspect argument is a mistake, not the default path."""
    result = cli("run", "cmg_open_loop", "--out", "", "--set", SHORT)
    assert_refused(result, "--out", "empty")
    assert everything_in(result.cwd) == []
    assert_refused(cli("inspect", ""), "rrd", "empty")


def test_out_under_an_existing_file(cli):
    (Path.cwd() / "f").write_text("keep")
    for out in ("f/x.rrd", "f/sub/x.rrd"):
        result = cli("run", "cmg_open_loop", "--out", out, "--set", SHORT)
        assert result.code == 2 and len(result.lines) == 1 and result.lines[0].startswith("error: --out: ")
        assert everything_in(result.cwd) == ["f"] and (result.cwd / "f").read_text() == "keep"


@pytest.mark.parametrize("out", ["/proc/x.rrd", "/proc/self/x.rrd", "/dev/null"])
def test_out_in_a_place_that_cannot_hold_a_trace(cli, out):
    assert_refused(cli("run", "cmg_open_loop", "--out", out, "--set", SHORT), "--out")


def test_out_whose_name_is_too_long_for_the_file_system(cli):
    assert_refused(cli("run", "cmg_open_loop", "--out", "n" * 300 + ".rrd", "--set", SHORT), "--out")


def test_out_in_missing_folders_refused_later_leaves_no_folders(cli):
    """A refusal that comes after --out was checked (here: a stage that does not fit the
    system) must not leave the folders created for the trace."""
    result = cli("run", "lebedev_spinup_ideal", "--out", "a/b/x.rrd", "--set", "model={system: planar}",
                 "--set", "initial=", "--set", NO_CHECKS)
    assert_refused(result, "pipeline.estimator.type")


def test_out_that_is_a_symlink_loop(cli):
    loop = Path.cwd() / "loop.rrd"
    loop.symlink_to(loop.name)
    result = cli("run", "cmg_open_loop", "--out", loop, "--set", SHORT)
    assert "Traceback" not in result.err, result.err
    assert result.code == 2 and len(result.lines) == 1 and result.lines[0].startswith("error: --out: ")
    assert everything_in(result.cwd) == ["loop.rrd"]


def test_sweep_out_that_is_an_existing_file_is_refused_before_any_case_runs(cli):
    existing = Path.cwd() / "table.csv"
    existing.write_text("mine\n")
    result = cli("sweep", "akor_sweep", "--out", existing, "--workers", "1")
    assert result.code == 2 and len(result.lines) == 1 and result.lines[0].startswith("error: --out: "), result.err
    assert "Traceback" not in result.err
    assert everything_in(result.cwd) == ["table.csv"] and existing.read_text() == "mine\n"


@pytest.mark.parametrize("argv, field", [
    (["--alpha-deg", "54.7356", "--h", "25", "--points", "100000000"], "--points"),
    (["--alpha-deg", "54.7356", "--h", "25", "--points", "0"], "--points"),
    (["--alpha-deg", "nan", "--h", "25"], "--alpha-deg"),
    (["--alpha-deg", "1e-300", "--h", "25"], "--alpha-deg"),
    (["--alpha-deg", "54.7356", "--h", "inf"], "--h"),
    (["--alpha-deg", "54.7356", "--h", "1e308"], "--h"),
    (["--alpha-deg", "54.7356", "--h", "1e-300"], "--h"),
])
def test_envelope_bad_arguments(cli, argv, field):
    assert_refused(cli("envelope", *argv, "--out", "e.rrd"), field)


@pytest.fixture(scope="module")
def real_run(tmp_path_factory) -> Path:
    """A small real trace (gyrostat_free, 5 s)."""
    folder = tmp_path_factory.mktemp("real")
    out = folder / "real.rrd"
    testbed.run(testbed.load("gyrostat_free", ["sim.duration_s=5"]), out=out)
    return out


def _foreign_rrd(path: Path) -> Path:
    import uuid

    import rerun as rr

    rec = rr.RecordingStream("someone-else", recording_id=str(uuid.uuid4()))
    rec.save(str(path))
    rec.log("random/points", rr.Points3D(np.random.default_rng(0).random((10, 3))))
    rec.log("random/scalar", rr.Scalars([1.0]))
    rec.flush()
    rec.disconnect()
    return path


def _forged_result_rrd(path: Path, text: str) -> Path:
    """An .rrd whose run/result entity holds `text` (a run's keys with values of the wrong type)."""
    import uuid

    import rerun as rr

    rec = rr.RecordingStream("gyrodyne-testbed", recording_id=str(uuid.uuid4()))
    rec.save(str(path))
    rec.log("run/result", rr.TextDocument(text, media_type="text/plain"), static=True)
    rec.flush()
    rec.disconnect()
    return path


@pytest.mark.parametrize("as_json", [False, True])
# (a run cut short is read as partial, exit 1: tests/test_hostile_disk.py)
@pytest.mark.parametrize("kind", ["foreign", "text", "empty", "random_bytes", "bad_json",
                                  "forged_types", "forged_list", "directory"])
def test_inspect_on_something_that_is_not_a_run(cli, inputs, real_run, kind, as_json):
    path = inputs / f"{kind}.rrd"
    if kind == "foreign":
        _foreign_rrd(path)
    elif kind == "text":
        path.write_text("hello, I am not a trace\n")
    elif kind == "empty":
        path.write_bytes(b"")
    elif kind == "random_bytes":
        path.write_bytes(np.random.default_rng(1).bytes(5000))
    elif kind == "bad_json":
        _forged_result_rrd(path, "{not json")
    elif kind == "forged_types":  # the right keys, values of the wrong types
        _forged_result_rrd(path, json.dumps({"scenario": "a", "sim_s": "1", "wall_s": 1, "status": "ok", "error": None,
                                             "metrics": {"m": "str"}, "checks": [1]}))
    elif kind == "forged_list":
        _forged_result_rrd(path, "[1, 2]")
    elif kind == "directory":
        path.mkdir()
    argv = ["inspect", path] + (["--json"] if as_json else [])
    assert_refused(cli(*argv), "rrd")


def test_inspect_reads_a_real_run(cli, real_run):
    result = cli("inspect", real_run, "--json")
    assert result.code == 0 and result.err == ""
    assert json.loads(result.out)["result"]["status"] == "ok"


@pytest.mark.parametrize("argv", [
    ["run", "n" * 300],
    ["run", "n" * 300 + ".yaml"],
    ["inspect", "n" * 300 + ".rrd"],
    ["check", "cmg_open_loop", "--out-dir", "n" * 300],
    ["run", "cmg_open_loop", "--set", "plugins=[" + "n" * 300 + ".py]"],
    ["run", "cmg_open_loop", "--set", 'plugins=["a\\0b.py"]'],
    ["run", "cmg_open_loop", "--out", "x/" + "n" * 300 + "/y.rrd", "--set", SHORT],
    ["sweep", "akor_sweep", "--out", "n" * 300, "--workers", "1", "--set", "sim.duration_s=0.02", "--set", NO_CHECKS],
    ["sweep", "akor_sweep", "--out", "x/" + "n" * 300, "--workers", "1", "--set", "sim.duration_s=0.02",
     "--set", NO_CHECKS],
    ["envelope", "--alpha-deg", "54.7356", "--out", "n" * 300 + ".rrd"],
    ["init", "n" * 300],
    ["init", "x/" + "n" * 300],
    ["init", "a\0b"],  # only through main(argv): a command line cannot hold a NUL
    ["run", "a\0b"],
    ["inspect", "a\0b"],
], ids=argv_id)
def test_names_the_file_system_refuses(cli, argv):
    """A name longer than the file system's 255 bytes, or with a NUL byte: bad input, not a
    traceback, and nothing created on the way (no parent folder left behind)."""
    assert_refused(cli(*argv))



@pytest.mark.parametrize("name", ["n" * 251 + ".rrd", "é" * 125 + "n.rrd"], ids=["251 ascii", "125 two-byte"])
def test_a_name_at_the_file_system_limit_is_written(cli, name):
    """A trace name of 255 bytes is a name the file system takes: the run writes it (its
    temporary file beside it keeps only the first bytes of the name, whole characters)."""
    assert len(name.encode()) == 255
    out = Path.cwd() / name
    stored = assert_ran(cli("run", "cmg_open_loop", "--out", out, "--set", SHORT), out)
    assert stored["status"] == "ok"

# --- 8. stages that do not fit the system -----------------------------------------------------

@pytest.mark.parametrize("scenario, duration", [
    ("reorient_minimax", 60), ("cmg_open_loop", 20),
    pytest.param("lebedev_spinup_cmg", 200, marks=pytest.mark.slow),  # past the observer's 150 s start-up
])
def test_ideal_torque_on_the_cmg_cluster_simply_runs(cli, scenario, duration):
    """Ideal body torques on the 4-CMG bus are a valid (if odd) experiment: it runs, and every
    metric that applies is computed (none dies)."""
    out = Path.cwd() / "x.rrd"
    result = cli("run", scenario, "--out", out, "--json", "--set", "pipeline.allocator={type: ideal_torque}",
                 "--set", NO_CHECKS, "--set", f"sim.duration_s={duration}")
    stored = assert_ran(result, out)
    assert result.err == ""
    assert stored["status"] == "ok", stored["error"]
    assert stored["metrics"] and all(np.isfinite(v) for v in stored["metrics"].values()), stored["metrics"]


def test_lebedev_pipeline_on_the_planar_rig(cli):
    result = cli("run", "lebedev_spinup_ideal", "--out", "x.rrd", "--set", "model={system: planar}",
                 "--set", "initial=", "--set", NO_CHECKS)
    assert_refused(result, "pipeline.estimator.type", "planar")


def test_lebedev_pipeline_on_the_planar_rig_with_its_checks(cli):
    """Keeping the scenario's own checks: still one line naming a part of the scenario."""
    result = cli("run", "lebedev_spinup_ideal", "--out", "x.rrd", "--set", "model={system: planar}", "--set", "initial=")
    assert_refused(result)


@pytest.mark.parametrize("axis", ["[1, 0, 0]", "[0.577, 0.577, 0.577]"])
def test_slew_law_on_the_planar_rig(cli, axis):
    result = cli("run", "planar_akor", "--out", "x.rrd", "--set", NO_CHECKS,
                 "--set", "pipeline.sensor={type: ideal_attitude}", "--set", "pipeline.estimator={type: attitude}",
                 "--set", f"pipeline.law={{type: slew, axis: {axis}, angle_deg: 10, duration_s: 10}}")
    assert_refused(result, "pipeline.law.type", "planar")


def test_sweep_case_that_does_not_fit_its_system(cli):
    sweep = ("{grid: {pipeline.law: [{type: akor_lqr, beta11: 1, beta22: 1, k: 1}, "
             "{type: slew, axis: [1, 0, 0], angle_deg: 10, duration_s: 10}]}}")
    result = cli("sweep", "akor_sweep", "--out", "sweep_out", "--workers", "1", "--set", NO_CHECKS,
                 "--set", f"sweep={sweep}")
    line = assert_refused(result, None, "planar")
    assert line.startswith("error: sweep")


def test_sweep_of_a_field_that_is_not_the_systems(cli):
    result = cli("sweep", "akor_sweep", "--out", "sweep_out", "--workers", "1",
                 "--set", "sweep={grid: {model.system: [planar, satellite]}}")
    assert_refused(result, None, "sweep")


def test_check_with_one_bad_file_writes_nothing(cli, inputs):
    good = shipped("cmg_open_loop") | {"name": "good"}
    good["sim"] = good["sim"] | {"duration_s": 1}
    bad = shipped("cmg_open_loop") | {"name": "bad"}
    bad["sim"] = bad["sim"] | {"duration_s": -1}
    good_path, bad_path = write_yaml(inputs, "good", good), write_yaml(inputs, "bad", bad)
    assert_refused(cli("check", good_path, bad_path), "sim.duration_s")
    assert_refused(cli("check", good_path, bad_path, "--out-dir", "traces"), "sim.duration_s")
    # a second file that parses but does not fit its system is refused before the first runs too
    planar = shipped("lebedev_spinup_ideal") | {"name": "planar_lebedev", "model": {"system": "planar"},
                                               "checks": {}}
    planar.pop("initial")
    assert_refused(cli("check", good_path, write_yaml(inputs, "planar_lebedev", planar)), "pipeline.estimator.type")


# --- 9. where the trace goes: symlinks and scenario names --------------------------------------

def test_out_that_is_a_symlink_is_written_through(cli):
    target_dir = Path.cwd() / "target"
    target_dir.mkdir()
    target = target_dir / "trace.rrd"
    target.write_text("old")
    link = Path.cwd() / "link.rrd"
    link.symlink_to(target)
    result = cli("run", "cmg_open_loop", "--out", link, "--set", SHORT, "--set", NO_CHECKS)
    assert result.code == 0, result.err
    assert link.is_symlink() and link.resolve() == target.resolve()
    assert target.is_file() and testbed.read(target).status == "ok"
    assert everything_in(result.cwd) == ["link.rrd", "target", "target/trace.rrd"]
    assert cli("inspect", link).code == 0


def test_out_that_is_a_dangling_symlink_is_written_through(cli):
    link = Path.cwd() / "link.rrd"
    link.symlink_to("target.rrd")
    result = cli("run", "cmg_open_loop", "--out", link, "--set", SHORT, "--set", NO_CHECKS)
    assert result.code == 0, result.err
    assert link.is_symlink() and (result.cwd / "target.rrd").is_file()


def test_trace_gets_the_permissions_of_an_ordinary_new_file(cli):
    umask = os.umask(0)
    os.umask(umask)
    out = Path.cwd() / "x.rrd"
    result = cli("run", "cmg_open_loop", "--out", out, "--set", SHORT, "--set", NO_CHECKS)
    assert result.code == 0
    assert out.stat().st_mode & 0o777 == 0o666 & ~umask, oct(out.stat().st_mode)


@pytest.mark.parametrize("name", ["/tmp/hostile_abs/evil", "../../x", "..", ".", ".hidden", "a/b/../../../c",
                                  "~/x", "C:\\\\x", '"\\u00e9t\\u00e9"'])
def test_scenario_name_cannot_escape_the_runs_folder(cli, tmp_path, name):
    result = cli("run", "cmg_open_loop", "--set", f"name={name}", "--set", SHORT, "--set", NO_CHECKS)
    assert result.code == 0, result.err
    written = [p for p in result.cwd.rglob("*") if p.is_file()]
    assert len(written) == 1 and written[0].parent == result.cwd / "runs", written
    assert written[0].suffix == ".rrd" and not written[0].name.startswith(".")
    assert not Path("/tmp/hostile_abs").exists()
    assert everything_in(tmp_path) == sorted(["cwd", "cwd/runs", f"cwd/runs/{written[0].name}"])


def test_scenario_name_too_long_for_a_file_name(cli):
    """A 300-character scenario name still makes a trace in runs/ (or is refused naming `name`)."""
    result = cli("run", "cmg_open_loop", "--set", "name=" + "n" * 300, "--set", SHORT, "--set", NO_CHECKS)
    assert "Traceback" not in result.err
    if result.code == 2:
        assert_refused(result, "name")
    else:
        assert result.code == 0 and len(list((result.cwd / "runs").glob("*.rrd"))) == 1


# --- 10. divergence and run-time failures: exit 1, a readable trace, nothing else -------------

@pytest.mark.parametrize("amplitude", ["1e9", "1e12"])
def test_diverged_run(cli, amplitude):
    out = Path.cwd() / "x.rrd"
    result = cli("run", "cmg_open_loop", "--out", out, "--json", "--set", "sim.duration_s=2",
                 "--set", f"pipeline.allocator.amplitude_deg_s=[{amplitude}, {amplitude}, {amplitude}, {amplitude}]")
    stored = assert_ran(result, out, codes=(1,))
    printed = json.loads(result.out)
    assert printed["status"] == stored["status"] == "diverged"
    assert "MuJoCo" in printed["error"] and "\n" not in printed["error"]
    assert not (result.cwd / "MUJOCO_LOG.TXT").exists()
    assert everything_in(result.cwd) == ["x.rrd"]
    assert result.err == ""
    assert cli("inspect", out).code == 0


@pytest.mark.parametrize("ticks", [1, 2])
@pytest.mark.parametrize("scenario", ["cmg_open_loop", "gyrostat_free", "torque_free_skylab", "gyrostat_sync",
                                      "gyrostat_program", "planar_akor", "lebedev_spinup_ideal", "reorient_minimax"])
def test_run_of_one_or_two_control_periods(cli, scenario, ticks):
    """The shortest valid runs: the analytic reference and the metrics have only 2-3 samples
    to work with; still exit 0 or 1 with a trace (a metric may be NaN and fail its check)."""
    sim = shipped(scenario)["sim"]
    control = sim.get("control_period_s", sim.get("dt_s", 0.002))
    out = Path.cwd() / "x.rrd"
    extra = ["--set", NO_CHECKS] if scenario == "planar_akor" else []  # its checks need the later phases
    result = cli("run", scenario, "--out", out, "--set", f"sim.duration_s={ticks * control!r}",
                 "--set", f"sim.trace_period_s={control!r}", *extra)
    assert_ran(result, out)
    assert result.err == ""


@pytest.mark.parametrize("amplitude", ["1e7", "3e7"])
def test_run_diverging_after_a_few_control_periods(cli, amplitude):
    """Divergence a few ticks in, with the reduced-model reference on: exit 1, status diverged."""
    out = Path.cwd() / "x.rrd"
    result = cli("run", "cmg_open_loop", "--out", out, "--json", "--set", "sim.duration_s=1",
                 "--set", f"pipeline.allocator.amplitude_deg_s=[{amplitude}, {amplitude}, {amplitude}, {amplitude}]")
    stored = assert_ran(result, out, codes=(1,))
    assert result.err == ""
    assert stored["status"] in ("diverged", "ok")


@pytest.mark.parametrize("scenario, assignment", [
    ("gyrostat_observer_arctan", "model.follower_omega_rad_s=[1e200, 0, 0]"),
    ("gyrostat_observer_arctan", "model.follower_omega_rad_s=[1e308, 0, 0]"),
    ("torque_free_skylab", "initial={omega_rad_s: [1e200, 0, 0]}"),
    ("gyrostat_free", "model.rotor_speed_rpm=1e300"),
])
def test_state_so_large_that_its_energy_overflows(cli, scenario, assignment):
    """Rates whose squares overflow a float: refused (exit 2) or a diverged run (exit 1), never
    a FloatingPointError from the plant's own read-outs."""
    out = Path.cwd() / "x.rrd"
    result = cli("run", scenario, "--out", out, "--set", assignment, "--set", "sim.duration_s=1")
    assert "Traceback" not in result.err
    if result.code == 2:
        assert_refused(result)
    else:
        assert assert_ran(result, out, codes=(1,))["status"] in ("diverged", "error")


@pytest.mark.slow
def test_diverged_run_in_a_fresh_process_writes_no_mujoco_log(tmp_path):
    code, out, err = run_subprocess(["run", "cmg_open_loop", "--out", "x.rrd", "--set", "sim.duration_s=2",
                                        "--set", "pipeline.allocator.amplitude_deg_s=[1e9, 1e9, 1e9, 1e9]"], tmp_path)
    assert code == 1 and "diverged" in out and err == "", err
    assert everything_in(tmp_path) == ["x.rrd"]


@pytest.mark.slow
def test_flagship_with_nonzero_total_momentum_fails_in_the_estimator(cli):
    """The fixed-gain observer cannot hold this momentum: its divergence ends the run, named as
    the method's (status method_failed, issue 37), not as a stage's crash."""
    out = Path.cwd() / "x.rrd"
    result = cli("run", "lebedev_spinup_cmg", "--out", out, "--set", "model.gimbal_angles_deg=[10, 20, 30, 40]")
    stored = assert_ran(result, out, codes=(1,))
    assert stored["status"] == "method_failed" and "observer diverged" in stored["error"], stored["error"]
    assert result.err == "", result.err  # no warnings
    lines = result.out.splitlines()
    assert lines[0].startswith("scenario lebedev_spinup_cmg: method_failed")
    assert lines[1].startswith("error: ") and "estimator" in lines[1]
    assert lines[-1] == f"trace: {out}"
    assert everything_in(result.cwd) == ["x.rrd"]
    inspected = cli("inspect", out, "--json")
    assert inspected.code == 0 and json.loads(inspected.out)["result"]["status"] == "method_failed"


# --- 11. unit vectors and quaternions: length within 1e-3 of 1, normalised ----------------------

def test_readme_slew_axis_is_accepted_and_normalised(cli):
    scenario = testbed.load("reorient_minimax", ["pipeline.law.axis=[0.577, 0.577, 0.577]"])
    axis = np.asarray(scenario.stages["law"][1].axis)
    assert np.linalg.norm(axis) == pytest.approx(1.0, abs=1e-12)
    assert axis == pytest.approx(np.ones(3) / np.sqrt(3), abs=1e-12)
    out = Path.cwd() / "x.rrd"
    result = cli("run", "reorient_minimax", "--out", out, "--set", "pipeline.law.axis=[0.577, 0.577, 0.577]",
                 "--set", "sim.duration_s=1", "--set", NO_CHECKS)
    assert_ran(result, out, codes=(0,))


@pytest.mark.parametrize("path, value, accepted", [
    ("pipeline.law.axis", "[1.0009, 0, 0]", True),
    ("pipeline.law.axis", "[0.9991, 0, 0]", True),
    ("pipeline.law.axis", "[1.0011, 0, 0]", False),
    ("pipeline.law.axis", "[0.5, 0.5, 0.5]", False),
    ("pipeline.law.axis", "[0, 0, 0]", False),
    ("pipeline.law.axis", "[1e308, 1e308, 0]", False),
    ("pipeline.law.axis", "[1e-300, 0, 0]", False),
    ("pipeline.law.axis", "[.nan, 0, 0]", False),
    ("initial.quat", "[0.9995, 0, 0, 0]", True),
    ("initial.quat", "[1.1, 0, 0, 0]", False),
    ("initial.quat", "[0, 0, 0, 0]", False),
    ("initial.quat", "[1e308, 0, 0, 0]", False),
    ("initial.quat", "[.inf, 0, 0, 0]", False),
])
def test_unit_vector_rule(cli, path, value, accepted):
    out = Path.cwd() / "x.rrd"
    result = cli("run", "reorient_minimax", "--out", out, "--set", f"{path}={value}", "--set", "sim.duration_s=0.5",
                 "--set", NO_CHECKS)
    if accepted:
        assert_ran(result, out, codes=(0,))
    else:
        assert_refused(result, None, path)


def test_rate_gyro_axis_as_typed_by_hand(cli):
    out = Path.cwd() / "x.rrd"
    result = cli("run", "lebedev_spinup_ideal", "--out", out, "--set", "pipeline.sensor.axis=[0.577, 0.577, 0.577]",
                 "--set", "sim.duration_s=1", "--set", NO_CHECKS)
    assert_ran(result, out, codes=(0,))


# --- 12. error messages quote at most ~80 characters of a value --------------------------------

LONG = "x" * 5000


@pytest.mark.parametrize("argv", [
    ["run", "cmg_open_loop", "--set", f"model.system={LONG}"],
    ["run", "cmg_open_loop", "--set", f"pipeline.allocator.type={LONG}"],
    ["run", "cmg_open_loop", "--set", f"reference.type={LONG}"],
    ["run", "cmg_open_loop", "--set", f"sim.integrator={LONG}"],
    ["run", "cmg_open_loop", "--set", f"name=[{LONG}]"],
    ["run", "cmg_open_loop", "--set", f"sim.duration_s={LONG}"],
    ["run", "cmg_open_loop", "--set", f"model.{LONG}=1"],
    ["run", "cmg_open_loop", "--set", f"{LONG}=1"],
    ["run", "cmg_open_loop", "--set", f"checks.{LONG}={{max: 1}}"],
    ["run", "cmg_open_loop", "--set", f"pipeline.{LONG}={{type: none}}"],
    ["run", "cmg_open_loop", "--set", f"a..{LONG}=1"],
    ["run", "cmg_open_loop", "--set", LONG],
    ["run", "cmg_open_loop", "--set", f"plugins=[{LONG}]"],
    ["run", LONG[:200]],
    ["sweep", "akor_sweep", "--set", f"sweep={{grid: {{pipeline.law.beta11: [{LONG}]}}}}"],
    ["envelope", "--alpha-deg", LONG],
    ["run", "cmg_open_loop", f"--{LONG}"],
], ids=argv_id)
def test_error_messages_quote_at_most_about_80_characters(cli, argv):
    result = cli(*[*argv, "--out", "x.rrd"] if argv[0] == "run" else argv)
    line = assert_refused(result)
    assert "x" * 100 not in line, f"{len(line)} characters: {line[:200]}..."


@pytest.mark.parametrize("key", ["a\nb", "a\rb", "a\u0085b", "a\u2028b", "a\x1b[2Jb"])
@pytest.mark.parametrize("where", ["checks", "model", "top"])
def test_error_message_stays_one_line_whatever_a_key_holds(cli, inputs, key, where):
    """A key with a line break (or a terminal control sequence) in it: still exactly one line."""
    data = shipped("cmg_open_loop")
    text = key
    if where == "checks":
        data["checks"][text] = {"max": 1}
    elif where == "model":
        data["model"][text] = 1
    else:
        data[text] = 1
    path = inputs / "keys.yaml"
    path.write_text(yaml.safe_dump(data, allow_unicode=False))  # the key written with YAML escapes
    assert text in read_yaml_of(path) or text in read_yaml_of(path)["checks"] or text in read_yaml_of(path)["model"]
    line = assert_refused(cli("run", path, "--out", "x.rrd"))
    assert not any(c in line for c in "\r\x1b\x85\u2028"), repr(line)


# --- 13. signals: 130 on SIGINT, 143 on SIGTERM, never a partial file -------------------------

SIGNALS = [(signal.SIGINT, 130), (signal.SIGTERM, 143)]


def _start(argv, cwd: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "testbed", *map(str, argv)], cwd=cwd, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _partials(folder: Path) -> list[str]:
    return [p.name for p in folder.rglob("*.partial")]


MARKER_PLUGIN = """\
# Touches the file named by TESTBED_TEST_MARKER when the scenario is loaded: the run starts next.
import os
import pathlib

pathlib.Path(os.environ["TESTBED_TEST_MARKER"]).touch()
"""


def _marked_scenario(folder: Path, name: str, duration_s: float) -> Path:
    """Shipped scenario `name` running `duration_s`, with a plug-in that marks when it is loaded."""
    (folder / "run_marker.py").write_text(MARKER_PLUGIN)
    data = shipped(name)
    data["plugins"] = ["run_marker.py"]
    data["sim"]["duration_s"] = duration_s
    return write_yaml(folder, name, data)


# `python -m testbed list`, with an import hook that marks when NumPy starts loading and holds
# it there 5 s: a signal then lands in the command's imports, whatever the machine's speed.
SLOW_IMPORT = """\
import pathlib, runpy, sys, time
marker = pathlib.Path(sys.argv[1])
class Hold:
    def find_spec(self, name, path=None, target=None):
        if name == "numpy":
            sys.meta_path.remove(self)
            marker.touch()
            time.sleep(5)
        return None
sys.meta_path.insert(0, Hold())
sys.argv = ["testbed", "list"]
runpy.run_module("testbed", run_name="__main__")
"""


@pytest.mark.parametrize("sig, expected", SIGNALS, ids=["SIGINT", "SIGTERM"])
def test_signal_while_the_command_imports(tmp_path, sig, expected):
    """Ctrl-C while NumPy (then MuJoCo, SciPy, Dask) loads: one line and 130, no traceback (before: a
    KeyboardInterrupt traceback from inside the imports); SIGTERM ends it by its default action
    (the shell's 143)."""
    marker = tmp_path / "importing"
    proc = subprocess.Popen([sys.executable, "-c", SLOW_IMPORT, str(marker)], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    t0 = time.monotonic()
    while not marker.exists() and proc.poll() is None and time.monotonic() - t0 < 30:
        time.sleep(0.01)
    assert marker.exists(), proc.communicate(timeout=60)
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=60)
    assert "Traceback" not in stderr, stderr
    assert proc.returncode in (expected, -sig), (proc.returncode, stderr)
    if sig == signal.SIGINT:
        assert (proc.returncode, stderr) == (130, "interrupted\n")


@pytest.mark.slow
@pytest.mark.parametrize("scenario", ["cmg_open_loop", "reorient_minimax"])
@pytest.mark.parametrize("sig, expected", SIGNALS, ids=["SIGINT", "SIGTERM"])
def test_signal_during_the_run(tmp_path, scenario, sig, expected):
    """Signal 0.7 s into an 8 s simulation (600 s simulated): exit 130/143, no trace, no partial
    file. reorient_minimax spends most of its time in the steering stage's Python code, so the
    signal usually lands inside a stage. (A plug-in in the scenario marks when the scenario has
    been loaded, so a slow start-up cannot make the signal arrive before the run.)"""
    inputs = tmp_path / "in"
    inputs.mkdir()
    scenario_file = _marked_scenario(inputs, scenario, 600)
    marker = tmp_path / "loaded"
    folder = tmp_path / "out"
    folder.mkdir()
    out = folder / "X.rrd"
    proc = subprocess.Popen([sys.executable, "-m", "testbed", "run", scenario_file, "--out", out], cwd=folder,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=os.environ | {"TESTBED_TEST_MARKER": str(marker)})
    t0 = time.monotonic()
    while not marker.exists() and proc.poll() is None and time.monotonic() - t0 < 30:
        time.sleep(0.01)
    assert marker.exists(), proc.communicate(timeout=60)
    time.sleep(0.7)
    assert proc.poll() is None, "the run ended before the signal"
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=60)
    assert "Traceback" not in stderr, stderr
    assert proc.returncode == expected, (proc.returncode, stdout[-1000:], stderr[-1000:])
    assert everything_in(folder) == []


@pytest.mark.slow
@pytest.mark.parametrize("sig, expected", SIGNALS, ids=["SIGINT", "SIGTERM"])
def test_signal_during_the_trace_write(tmp_path, sig, expected):
    """Signal while the .rrd is being written: a run of 6e4 trace samples (about 2 s of
    simulation, about 0.1 s of writing). The signal is sent once a *.partial file has been
    seen twice 2 ms apart (the --out check's own probe file lives for microseconds), at once
    or 0.03 s later (three attempts). Exit 130/143 every time, nothing left but, possibly,
    a whole trace; at least one attempt must have stopped the write itself (no trace)."""
    argv = ["--set", "sim.duration_s=600", "--set", "sim.dt_s=0.01", "--set", "sim.control_period_s=0.01",
            "--set", "sim.trace_period_s=0.01"]
    failures, interrupted_writes = [], 0
    for attempt, delay in enumerate([0.0, 0.03, 0.0]):
        folder = tmp_path / f"attempt{attempt}"
        folder.mkdir()
        out = folder / "X.rrd"
        proc = _start(["run", "torque_free_skylab", "--out", out, *argv], folder)
        seen, previous = False, set()
        while proc.poll() is None:
            now = set(_partials(folder))
            if now & previous:
                seen = True
                break
            previous = now
            time.sleep(0.002)
        ended_first = False
        if seen:
            time.sleep(delay)
            # on a loaded machine the write may be over before the delay is: no signal reaches
            # the process, and a finished run (exit 0, a whole trace) is the right outcome
            ended_first = proc.poll() is not None
            proc.send_signal(sig)
        stdout, stderr = proc.communicate(timeout=60)
        assert seen, f"the trace write was not caught (exit {proc.returncode}): {stderr[-500:]}"
        whole = not out.exists() or subprocess.run([sys.executable, "-m", "testbed", "inspect", out],
                                                   capture_output=True).returncode == 0
        interrupted_writes += not out.exists()
        status = 0 if ended_first else expected
        if proc.returncode != status or _partials(folder) or "Traceback" in stderr or not whole:
            failures.append(f"attempt {attempt} (delay {delay} s): exit {proc.returncode}, left "
                            f"{everything_in(folder)}, stderr {stderr[-600:]!r}")
    assert not failures, "\n".join(failures)
    assert interrupted_writes, "no attempt hit the write itself: the timing of this test needs a look"


@pytest.mark.parametrize("where", ["RecordingStream", "set_sinks", "send_columns", "log", "flush", "disconnect"])
@pytest.mark.parametrize("interrupt, expected", [("KeyboardInterrupt", 130), ("_Terminated", 143)],
                         ids=["SIGINT", "SIGTERM"])
def test_interrupt_at_each_step_of_the_trace_write(cli, monkeypatch, where, interrupt, expected):
    """What the SIGINT/SIGTERM handlers raise (KeyboardInterrupt; testbed.cli's _Terminated),
    raised in turn at each Rerun call of the trace write, deterministically: exit 130/143 and
    nothing left in the --out folder, whatever step it interrupts (creating the recording
    stream included, which comes after the temporary file exists). One signal: the step is
    interrupted once, a second call of it (the clean-up's) works."""
    import rerun as rr

    import testbed.interrupts

    exc = KeyboardInterrupt if interrupt == "KeyboardInterrupt" else testbed.interrupts.Terminated
    owner = rr if where == "RecordingStream" else rr.RecordingStream
    original, calls = getattr(owner, where), []

    def interrupted_once(*args, **kwargs):  # one signal: the first call is interrupted, later ones work
        calls.append(where)
        if len(calls) == 1:
            raise exc()
        return original(*args, **kwargs)

    monkeypatch.setattr(owner, where, interrupted_once)
    result = cli("run", "cmg_open_loop", "--out", "x.rrd", "--set", SHORT, "--set", NO_CHECKS)
    assert "Traceback" not in result.err, result.err
    assert result.code == expected, (result.code, result.out, result.err)
    assert everything_in(result.cwd) == []


@pytest.fixture(scope="module")
def signalling_plugin(tmp_path_factory) -> Path:
    """A plug-in law that sends its own process a signal (`signal_number`) at `at_s`: the signal
    then arrives while a stage is running, deterministically. One folder per process: xdist may
    build a module fixture twice in one worker, and a second file would register the law twice."""
    folder = tmp_path_factory.getbasetemp() / "signalling_plugin"
    folder.mkdir(exist_ok=True)
    (folder / "hostile_signal_law.py").write_text(textwrap.dedent('''\
        import os
        from dataclasses import dataclass

        import numpy as np
        import testbed


        @dataclass
        class Params:
            signal_number: int = testbed.param(15)
            at_s: float = testbed.param(0.5, ge=0)
            in_finalizer: bool = testbed.param(False)


        class SignalsWhenCollected:
            """Sends the signal from its finalizer, so the handler runs inside a __del__ (as it
            does when it lands in the one Rerun runs inside every log call)."""

            def __init__(self, signum):
                self.signum = signum

            def __del__(self):
                os.kill(os.getpid(), self.signum)
                sum(range(10000))  # bytecodes: the handler runs here, inside the finalizer


        @testbed.stage("law", "hostile.signal_self", Params)
        class SignalSelf:
            outputs = ("torque",)

            def __init__(self, params, ctx):
                self.params, self.sent = params, False

            def torque(self, t, estimate):
                if t >= self.params.at_s and not self.sent:
                    self.sent = True
                    if self.params.in_finalizer:
                        SignalsWhenCollected(self.params.signal_number)  # collected at once
                    else:
                        os.kill(os.getpid(), self.params.signal_number)
                return {"torque": np.zeros(3)}
        '''))
    scenario = shipped("torque_free_skylab") | {
        "name": "signal_self", "plugins": ["hostile_signal_law.py"],
        "pipeline": {"law": {"type": "hostile.signal_self"}, "allocator": {"type": "ideal_torque"}},
        "checks": {}, "reference": None}
    scenario["sim"] = scenario["sim"] | {"duration_s": 10}
    return write_yaml(folder, "signal_self", scenario)


@pytest.mark.parametrize("sig, expected", SIGNALS, ids=["SIGINT", "SIGTERM"])
def test_signal_that_arrives_inside_a_stage(cli, signalling_plugin, sig, expected):
    """The handler runs while the law's code runs: the run must stop with 130/143, not be
    reported as a failure of that stage (exit 1, status error, a trace written)."""
    out = Path.cwd() / "X.rrd"
    result = cli("run", signalling_plugin, "--out", out, "--set", f"pipeline.law.signal_number={int(sig)}")
    assert "Traceback" not in result.err, result.err
    assert result.code == expected, (result.code, result.out[-1000:], result.err)
    assert everything_in(result.cwd) == []


@pytest.mark.parametrize("sig, expected", SIGNALS, ids=["SIGINT", "SIGTERM"])
def test_signal_that_arrives_inside_a_finalizer(cli, signalling_plugin, sig, expected):
    """The handler runs inside a __del__, where Python prints the exception it raises as
    "Exception ignored" and drops it: the signal must still stop the run with 130/143."""
    out = Path.cwd() / "X.rrd"
    result = cli("run", signalling_plugin, "--out", out, "--set", f"pipeline.law.signal_number={int(sig)}",
                 "--set", "pipeline.law.in_finalizer=true")
    assert "Traceback" not in result.err and "ignored" not in result.err, result.err
    assert result.code == expected, (result.code, result.out[-1000:], result.err)
    assert everything_in(result.cwd) == []


class _SignalsWhenCollected:
    """Raises SIGINT in its own finalizer: the handler runs inside the __del__."""

    def __del__(self):
        signal.raise_signal(signal.SIGINT)


def test_a_signal_inside_a_finalizer_is_raised_after_it():
    """In process: the handler, run inside a __del__, does not raise there (Python would drop it)
    but repeats the signal a moment later, outside, where it raises KeyboardInterrupt."""
    from testbed.interrupts import signals_as_exceptions

    with pytest.raises(KeyboardInterrupt), signals_as_exceptions():
        _SignalsWhenCollected()
        time.sleep(1.0)  # the repeat lands here


def test_a_repeat_after_the_block_has_ended_is_dropped():
    """The repeat of a signal handled inside a finalizer just before the block ends would land
    outside it, under the default handler: it is not sent."""
    from testbed.interrupts import REDELIVERY_DELAY_S, signals_as_exceptions

    with signals_as_exceptions():
        _SignalsWhenCollected()
    time.sleep(50 * REDELIVERY_DELAY_S)  # a KeyboardInterrupt here fails the test


def test_a_signal_ignored_at_start_stays_ignored():
    """`nohup testbed run ...` or a background job of a non-interactive shell starts with SIGINT
    ignored: the command line's handlers must not make such a run stoppable by it."""
    from testbed.interrupts import signals_as_exceptions

    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with signals_as_exceptions():
            signal.raise_signal(signal.SIGINT)  # would raise KeyboardInterrupt if handled
            assert signal.getsignal(signal.SIGINT) == signal.SIG_IGN
            assert signal.getsignal(signal.SIGTERM) not in (signal.SIG_DFL, signal.SIG_IGN)
        assert signal.getsignal(signal.SIGINT) == signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, previous)


def _signalling_partial_beside(signum):
    """partial_beside that makes its file, then takes `signum` before it returns: the moment a
    loaded machine can deschedule a run (seen once: SIGQUIT left `.t.rrd.<random>.partial`)."""
    from testbed.recording import atomic_file

    def made_then_signalled(path):
        made = atomic_file.tempfile.mkstemp(dir=Path(path).parent, prefix=f".{Path(path).name}.", suffix=".partial")
        signal.raise_signal(signum)
        return made
    return made_then_signalled


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGQUIT])
def test_a_signal_while_the_trace_file_is_made_leaves_nothing(tmp_path, monkeypatch, signum):
    """The signal is held until the temporary name is kept, then raised: the way out removes it."""
    from testbed.interrupts import Terminated, signals_as_exceptions
    from testbed.recording import trace

    monkeypatch.setattr(trace, "partial_beside", _signalling_partial_beside(signum))
    with pytest.raises(Terminated), signals_as_exceptions():
        with trace.recording_to(tmp_path / "t.rrd"):
            pass
    assert everything_in(tmp_path) == []


def test_a_signal_while_an_atomic_file_is_made_leaves_nothing(tmp_path, monkeypatch):
    from testbed.interrupts import Terminated, signals_as_exceptions
    from testbed.recording import atomic_file

    monkeypatch.setattr(atomic_file, "partial_beside", _signalling_partial_beside(signal.SIGTERM))
    with pytest.raises(Terminated), signals_as_exceptions():
        atomic_file.write_atomically(tmp_path / "table.csv", "a,b\n")
    assert everything_in(tmp_path) == []


def test_an_atomic_file_that_cannot_be_opened_leaves_nothing(tmp_path, monkeypatch):
    """The temporary file made, its opening refused (OSError): WriteFailed naming the path, and
    the temporary file removed (before: left beside the path)."""
    from testbed.errors import WriteFailed
    from testbed.recording import atomic_file

    def refused(*args, **kwargs):
        raise OSError(24, "Too many open files")
    monkeypatch.setattr(atomic_file.os, "fdopen", refused)
    with pytest.raises(WriteFailed):
        atomic_file.write_atomically(tmp_path / "table.csv", "a,b\n")
    assert everything_in(tmp_path) == []


# --- 14. two runs writing one --out at the same time ------------------------------------------

@pytest.mark.slow
def test_two_concurrent_runs_to_one_out_leave_a_whole_trace(tmp_path):
    out = tmp_path / "X.rrd"
    argv = ["run", "cmg_open_loop", "--out", out, "--set", "sim.duration_s=60"]  # under a second each, quiet
    procs = [_start(argv, tmp_path) for _ in range(2)]
    results = [proc.communicate(timeout=120) for proc in procs]
    for proc, (stdout, stderr) in zip(procs, results):
        assert proc.returncode == 0, (stdout[-500:], stderr[-1000:])
        assert stderr == ""
    assert everything_in(tmp_path) == ["X.rrd"]
    code, stdout, stderr = run_subprocess(["inspect", out, "--json"], tmp_path)
    assert code == 0, stderr
    assert json.loads(stdout)["result"]["status"] == "ok"


# --- 15. a closed stdout ------------------------------------------------------------------------

@pytest.mark.parametrize("argv, code", [
    (["run", "torque_free_tumble", "--out", "x.rrd", "--set", SHORT, "--set", "checks.final_omega_rad_s.max=0"], 1),
    (["run", "torque_free_tumble", "--out", "x.rrd", "--set", SHORT], 0),
    (["list"], 0)], ids=["failing run", "passing run", "list"])
def test_a_reader_that_goes_away_keeps_the_exit_status(tmp_path, argv, code):
    """`testbed run <a failing run> | head -1`, `testbed list | head -0`: the reader has gone
    when the output is printed (closed before the command starts, so that every write meets the
    broken pipe, not only those of a slow reader). No traceback, and the exit status stays the
    command's own (it was 0 for a failing run)."""
    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        proc = subprocess.run([sys.executable, "-m", "testbed", *argv], cwd=tmp_path, stdout=write_end,
                              stderr=subprocess.PIPE, text=True, timeout=60)
    finally:
        os.close(write_end)
    assert "Traceback" not in proc.stderr, proc.stderr
    assert proc.returncode == code, proc.stderr


# --- 16. the API takes what a YAML file holds ---------------------------------------------------

def test_a_mapping_from_safe_load_is_read_as_the_loader_reads_the_file(tmp_path):
    """PyYAML's safe_load reads `1e-9` (no dot) as a string; testbed.run of that mapping reads it
    as the number, as `testbed run FILE` does: the same result as the file."""
    text = (SCENARIO_DIR / "torque_free_tumble.yaml").read_text()
    data = yaml.safe_load(text)
    data["sim"]["duration_s"] = "2e1"  # written as a file would have it
    data["checks"] = {"momentum_drift_rel": {"max": "1e-9"}}
    assert isinstance(data["sim"]["duration_s"], str)
    result = testbed.run(data)
    assert result.status == "ok" and result.sim_s == pytest.approx(20.0)
    assert result.checks[0]["limit"] == "<= 1e-09" and result.checks[0]["passed"]
    path = write_yaml(tmp_path, "again", {**data, "sim": {**data["sim"], "duration_s": 20.0},
                                          "checks": {"momentum_drift_rel": {"max": 1e-9}}})
    assert testbed.run(path).metrics == result.metrics
    with pytest.raises(testbed.InputError, match="sim.duration_s"):
        testbed.run({**data, "sim": {**data["sim"], "duration_s": "twenty"}})


@pytest.mark.parametrize("out", [123, b"x.rrd", ["x.rrd"], 1.5])
def test_an_out_that_is_not_a_path_is_refused(tmp_path, monkeypatch, out):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(testbed.InputError, match="^out: must be a file path"):
        testbed.run(testbed.load("torque_free_tumble", [SHORT]), out=out)
    assert everything_in(tmp_path) == []


def test_a_run_that_diverges_at_its_first_tick_stores_its_own_result(tmp_path):
    """Found by the fuzz: a leader rate of 1e308 overflows at t = 0, before any chunk is
    flushed, so the "did not finish" placeholder and the result share one chunk; the stored
    result is the run's (diverged), not the placeholder (it read back as 'error')."""
    data = shipped("gyrostat_observer_arctan")
    data["model"]["leader_omega_rad_s"] = [1e100, 0.2, 0.3]  # (1e308 is now refused at load)
    data["sim"]["duration_s"] = 0.05
    result = testbed.run(data, out=tmp_path / "x.rrd")
    assert result.status == "diverged"
    assert testbed.read(tmp_path / "x.rrd").status == "diverged"


# --- second hostile round (its findings by number) ------------------------------------------

def _short_sweep(folder: Path, sweep: dict) -> Path:
    """A one-second planar scenario (test_sweep's BASE) with this `sweep:` block."""
    from test_sweep import BASE

    return write_yaml(folder, "mini", dict(BASE, sim=dict(BASE["sim"], duration_s=1), checks={}, sweep=sweep))


@pytest.mark.parametrize("size", [1001, 10**9])
def test_a_dispersion_size_past_its_bound_is_refused_at_once(cli, inputs, size):
    """#1: `size: 1e9` drew 1e9 numbers per case before anything was checked (a hang); the bound
    (MAX_SIZE components, each a table column) is a schema bound, checked at load."""
    scenario = _short_sweep(inputs, {"seed": 3, "samples": 2, "dispersions": {
        "pipeline.law.k": {"uniform": [1, 2], "size": size}}})
    result = cli("sweep", scenario, "--workers", "1", "--out", "out")
    assert_refused(result, "sweep.dispersions.pipeline.law.k.size", "<= 1000")


def _api_refusal(call, field: str) -> str:
    """The InputError `call()` raises (never a raw TypeError or RecursionError): its message."""
    with pytest.raises(testbed.InputError) as caught:
        call()
    assert caught.value.field.startswith(field), caught.value.field
    assert "\n" not in str(caught.value)
    return str(caught.value)


@pytest.mark.parametrize("overrides, field", [([None], "--set"), ([3], "--set"), (None, "overrides"),
                                              ("sim.duration_s=1", "overrides")])
def test_overrides_that_are_not_strings_are_bad_input(overrides, field):
    """#16: `load(name, [None])` raised TypeError."""
    _api_refusal(lambda: testbed.load("cmg_open_loop", overrides), field)


def test_a_mapping_that_contains_itself_is_bad_input(tmp_path, monkeypatch):
    """#17: a cycle recursed until RecursionError."""
    monkeypatch.chdir(tmp_path)
    data = {"name": "x", "model": {"system": "satellite"}}
    data["model"]["self"] = data
    assert "contains itself" in _api_refusal(lambda: testbed.run(data), "model.self.model")
    looped = [1]
    looped.append(looped)
    _api_refusal(lambda: testbed.run({"name": "x", "model": {"system": "satellite"}, "sim": {"a": looped}}), "sim.a.1")
    assert everything_in(tmp_path) == []


def _nested(levels: int) -> dict:
    """{"sim": {"a": {"a": ... {"a": 1}}}}: the top mapping plus `levels` levels below it."""
    inner: object = 1
    for _ in range(levels - 1):
        inner = {"a": inner}
    return {"sim": inner}


@pytest.mark.parametrize("levels", [18, 19, 20, 21, 5000])
def test_a_mapping_nested_deeper_than_a_file_may_be_is_refused_as_the_file_is(tmp_path, levels):
    """#18: 5000 levels raised RecursionError. The API's bound is the file loader's: the same
    mapping, dumped to YAML text and read by the loader (a second path), is refused iff the API
    refuses it."""
    from testbed.scenario.yaml_reading import as_loaded, yaml_load

    data = _nested(levels)
    file_refuses = levels > 1000  # too deep for yaml.safe_dump itself: the loader's refusal is certain
    if not file_refuses:
        try:
            yaml_load(yaml.safe_dump(data), "file")
        except testbed.InputError:
            file_refuses = True
    if file_refuses:
        _api_refusal(lambda: as_loaded(data), "sim.a")
        _api_refusal(lambda: testbed.run({"name": "x", "model": {"system": "satellite"}, **data}), "sim.a")
    else:
        assert as_loaded(data) == data
    assert file_refuses == (levels >= 20)  # 20 levels of nodes: 19 mappings and the value in the last


def test_a_progress_that_is_not_callable_is_refused_before_the_run(tmp_path, monkeypatch):
    """#19: progress="x" raised TypeError mid-run."""
    monkeypatch.chdir(tmp_path)
    _api_refusal(lambda: testbed.run("cmg_open_loop", out="x.rrd", progress="x", overrides=[SHORT]), "progress")
    assert everything_in(tmp_path) == []


@pytest.mark.parametrize("path", [None, 3, 1.5, ["x.rrd"]])
@pytest.mark.parametrize("reader", ["read", "inspect"])
def test_a_trace_path_that_is_not_a_path_is_bad_input(reader, path):
    """#20: read(None) / read(3) / inspect(None) raised TypeError."""
    from testbed import api

    _api_refusal(lambda: getattr(api, reader)(path), "rrd")


@pytest.mark.parametrize("target", ["target", "made/below/target"])
def test_a_sweep_out_that_is_a_dangling_symlink_is_written_through(cli, inputs, target):
    """#2: `--out` a symlink to nothing raised FileExistsError from mkdir; the campaign folder is
    made where the link points (as `run --out` writes through a link), the link stays."""
    scenario = _short_sweep(inputs, {"grid": {"pipeline.law.k": [1.0, 4.0]}})
    link = Path.cwd() / "out"
    link.symlink_to(target)
    result = cli("sweep", scenario, "--workers", "1", "--out", "out")
    assert result.code == 0 and "Traceback" not in result.err, result.err
    assert link.is_symlink() and (result.cwd / target / "mini_sweep.csv").is_file()
    assert (result.cwd / target / "summary" / "summary.json").is_file()


# --- the third round's smaller breaks (issue 37, finding 8) ---------------------------------------

def test_init_with_an_empty_folder_name_writes_nothing(tmp_path, monkeypatch, capsys):
    """Path('') is '.': `testbed init ''` wrote the templates into the current folder, exit 0."""
    monkeypatch.chdir(tmp_path)
    assert main(["init", ""]) == 2
    assert capsys.readouterr().err.startswith("error: DIR: is empty") and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("assignment, field, words", [
    ("pipeline.allocator.gimbal_angle_limits_deg=[[-1000, 1000], null, null, null]",
     "pipeline.allocator.gimbal_angle_limits_deg[0]", "within one turn of zero"),
    ("pipeline.sensor.gyro.seed=18446744073709551615", "pipeline.sensor.gyro.seed", "within +-(2^63 - 1)"),
])
def test_a_figure_beyond_its_meaning_is_refused(tmp_path, monkeypatch, capsys, assignment, field, words):
    monkeypatch.chdir(tmp_path)
    scenario = "attitude_hold_mekf" if "gyro" in assignment else "reorient_gimbal_limits"
    assert main(["run", scenario, "--set", assignment]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {field}: ") and words in err and len(err.strip().splitlines()) == 1, err


@pytest.mark.filterwarnings("error")
def test_a_huge_torque_through_the_api_gives_no_numpy_warning():
    """A law's 1e300 N m overflowed the torque metrics' squares with a raw RuntimeWarning; the
    metric is now not finite and fails its check with the reason."""
    result = testbed.run("reorient_minimax", overrides=["sim.duration_s=1"],
                         stages={"law": lambda t, estimate: {"torque": np.array([1e300, 0.0, 0.0])}})
    assert result.status == "ok" and result.metrics["torque_error_rms"] == np.inf
    row = next(c for c in result.checks if c["name"] == "torque_error_rel")
    assert not row["passed"] and row["reason"] == "the recorded signals give no finite value"


# --- floating-point edges as input errors (issue 37) ------------------------------------------------

@dataclass(kw_only=True)
class _OneNumber:
    x_m: float = testbed.param(1.0)


@settings(max_examples=400, deadline=None)
@given(st.floats(allow_nan=False, allow_infinity=False))
def test_every_number_is_zero_or_within_1e100_decades(x):
    """A number whose square would under- or overflow a double is refused where it is read, naming
    the field (a tracker noise of 1e-300 arcsec failed as 'FloatingPointError: underflow')."""
    from testbed.scenario import schema

    if x == 0 or 1e-100 <= abs(x) <= 1e100:
        assert schema.load(_OneNumber, {"x_m": x}, "block").x_m == x
        assert x == 0 or 0 < (x * x) < math.inf  # its square is an ordinary double
    else:
        with pytest.raises(InputError) as refused:
            schema.load(_OneNumber, {"x_m": x}, "block")
        assert refused.value.field == "block.x_m" and "in magnitude" in refused.value.reason


def test_a_part_that_cannot_be_built_names_its_most_extreme_number(tmp_path, monkeypatch, capsys):
    """A spin rate of 1e-100 deg/s underflows the Lebedev observer's design: the message named the
    estimator and numpy's exception, now the law's field that holds the number."""
    monkeypatch.chdir(tmp_path)
    assert main(["run", "lebedev_spinup_cmg", "--set", "pipeline.law.spin_rate_deg_s=1e-100"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: pipeline.law.spin_rate_deg_s: 1e-100 is too small to build pipeline.estimator "
                          "(lebedev) from: its arithmetic leaves double precision"), err
    assert "Error" not in err and list(tmp_path.iterdir()) == []


@pytest.mark.filterwarnings("error")
def test_a_run_closed_after_two_periods_gives_no_numpy_warning():
    """Metrics of a run too short for them (an all-NaN window) printed numpy's 'All-NaN slice'."""
    sim = testbed.Simulation("orbit_momentum_management", ["sim.duration_s=20"], keep_trace=False)
    sim.step(), sim.step()
    result = sim.close()
    assert result.status == "ok" and not all(np.isfinite(list(result.metrics.values())))


def test_a_law_without_an_allocator_is_refused_not_flown_open_loop(cli):
    """The plant takes only the allocator's command: a law with allocator none would fly open
    loop without a word (a pointing law on a rigid satellite drifted 0.4 deg). It is refused at
    load, naming pipeline.allocator; a stepped run may still give the command at each step."""
    from testbed.stepping.simulation import Simulation
    override = "pipeline.allocator={type: none}"
    assert_refused(cli("run", "reorient_minimax", "--out", "x.rrd", "--set", override, "--set", NO_CHECKS),
                   "pipeline.allocator", "never reach")
    with Simulation(testbed.load("reorient_minimax", [override, NO_CHECKS, SHORT])) as sim:  # the caller's command
        sim.step({"allocator": {"gimbal_rates": np.zeros(4)}})
