"""Property-based fuzzing of `testbed run` (hypothesis): every shipped scenario mutated at random
must end in one of the README's exit statuses, never in a traceback.

Mutations: delete a field; replace one by a value of another type (string, list, mapping,
number, None, bool) or by an extreme or non-finite number (1e308, -1e308, nan, inf, 1e-300,
0, huge integers); scale a number by -1 or 1e-6 ... 1e6 (likely still valid, so that the run
itself is exercised); cut or stretch a list; add an invented key; give the whole document as a
non-mapping; random `--set key.path=value` with paths built from real and invented keys; or
random bytes as the whole file. The mutated scenario is written to a temporary folder and run
in-process with `testbed.cli.main(["run", FILE, "--out", FOLDER/x.rrd, ...])`.

Properties (README "Exit status"):
- the status is 0, 1 or 2, and nothing on stdout or stderr is a Python traceback;
- 2: exactly one line on stderr, `error: <field>: <reason>`, of bounded length, nothing on
  stdout and no file written (the folder holds only the scenario file);
- 0 or 1: the .rrd exists, `testbed.read` reads it back with the status printed, no partial
  file is left and nothing is written to stderr.

Runs are kept short: unless a mutation targets `sim.duration_s` itself, the duration is set
to 1-6 trace periods AFTER mutating; a mutated duration is one of the extreme values, which
must be refused. A watchdog fails an example that takes longer than WATCHDOG_S (a hang).
Both tests are derandomized (no example database), so CI sees the same examples every time.
"""

from __future__ import annotations

import copy
import math
import os
import shutil
import signal
import tempfile
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import testbed
from testbed.cli import main
from testbed.scenario.yaml_reading import read_yaml
from testbed.scenario.shipped_files import SCENARIO_DIR

SCENARIOS = {path.stem: read_yaml(path) for path in sorted(SCENARIO_DIR.glob("*.yaml"))}
NAMES = sorted(SCENARIOS)

WATCHDOG_S = 60.0
MAX_STEPS = 1_000_000  # physics steps a valid mutated run may take (larger valid runs are skipped)
MAX_ERROR_LINE = 1000  # characters: field + reason (lists of known names included), ~80 quoted of a value

# --- values ---------------------------------------------------------------------------------

class _NoAliases(yaml.SafeDumper):
    """Writes a value that occurs twice twice (the strict loader refuses anchors and aliases)."""

    def ignore_aliases(self, data):
        return True


EXTREME_NUMBERS = [1e308, -1e308, float("nan"), float("inf"), float("-inf"), 1e-300, -1e-300, 5e-324, 0, 0.0,
                   -0.0, -1, 1, 10**30, -(10**30), 2**63, 2**64 + 1, 10**400]
# Strings that are none of Python's module names (a mutated `plugins:` list imports what it names).
STRINGS = ["", " ", "x y", "none", "RK4", "satellite", "planar", "cmg_rhombus", "ideal_torque", "minimax", "slew",
           "torque_free", "1e308", ".nan", "true", "null", "[", "{a: 1}", "é ü 漢字", "\x00", "a\x00b.py",
           "../../etc/passwd", "/", "nonexistent plugin.py", "~", "x" * 300, "line\nbreak", "*a", "&a", "!!python/none"]
INVENTED_KEYS = ["zz", "", "type", "system", "duration_s", "max", "min", "0", "__class__", "a b", "ü", "sweep",
                 "plugins", "inertia_kg_m2", "omega_rad_s", "grid"]

scalars = (st.sampled_from(EXTREME_NUMBERS) | st.sampled_from(STRINGS) | st.none() | st.booleans()
           | st.integers(min_value=-(2**70), max_value=2**70)
           | st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True)
           | st.text(max_size=12).map(lambda s: s + " §"))  # a space: never a module name
keys = st.sampled_from(INVENTED_KEYS) | st.integers(-3, 3) | st.text(max_size=6).map(lambda s: s + " k")
values = st.recursive(scalars, lambda inner: st.lists(inner, max_size=5) | st.dictionaries(keys, inner, max_size=4),
                      max_leaves=8)
yaml_texts = (st.sampled_from(["1", "-1", "0", "1e308", "-1e308", ".nan", ".inf", "-.inf", "1e-300", "[1, 2]",
                               "[1, 2, 3, 4, 5]", "[]", "{}", "{a: 1}", "{type: none}", "null", "", "~", "true",
                               "'str'", "[", "}", "&a [1]", "[&a [1], *a]", "!!python/object/apply:os.getcwd []",
                               "99999999999999999999999", "[[[[1]]]]", "{max: 1}", "{max: .nan}", "RK4", "none",
                               "ideal_torque", "[.nan, 0, 0]", "[1e308, 1e308, 1e308]", "[0, 0, 0, 0]"])
              | values.map(lambda v: yaml.dump(v, Dumper=_NoAliases, default_flow_style=True, width=10**9).strip()))



def _dump(document) -> str:
    return yaml.dump(document, Dumper=_NoAliases, sort_keys=False, allow_unicode=True, width=10**9)


# --- mutations --------------------------------------------------------------------------------

def _paths(node, prefix=()):
    """Every path (tuple of keys and indices) into the nested mapping/list `node`."""
    found = []
    if isinstance(node, dict):
        for key, child in node.items():
            found.append(prefix + (key,))
            found += _paths(child, prefix + (key,))
    elif isinstance(node, list):
        for i, child in enumerate(node):
            found.append(prefix + (i,))
            found += _paths(child, prefix + (i,))
    return found


def _parent(document, path):
    node = document
    for part in path[:-1]:
        node = node[part]
    return node


def _mutate(draw, document, kind):
    """Apply one mutation of `kind` to `document` in place (or return a replacement); returns
    (document, touched path or None)."""
    paths = _paths(document) if isinstance(document, dict) else []
    if kind == "non_mapping":
        return draw(values.filter(lambda v: not isinstance(v, dict))), None
    if not paths:
        return document, None
    path = draw(st.sampled_from(paths))
    parent = _parent(document, path)
    if kind == "delete":
        del parent[path[-1]]
    elif kind == "replace":
        parent[path[-1]] = draw(values)
    elif kind == "extreme":
        parent[path[-1]] = draw(st.sampled_from(EXTREME_NUMBERS))
    elif kind == "perturb":  # a plausible but odd number: likely valid, so the run itself is exercised
        numeric = [p for p in paths if _number(abs(_parent(document, p)[p[-1]])
                                               if isinstance(_parent(document, p)[p[-1]], (int, float)) else None)]
        if not numeric:
            return document, None
        path = draw(st.sampled_from(numeric))
        parent = _parent(document, path)
        parent[path[-1]] = parent[path[-1]] * draw(st.sampled_from([-1, 0.5, 2, 10, 1e3, 1e6, 1e-3, 1e-6]))
    elif kind == "resize":
        lists = [p for p in paths if isinstance(_parent(document, p)[p[-1]], list)]
        if not lists:
            return document, None
        path = draw(st.sampled_from(lists))
        items = _parent(document, path)[path[-1]]
        if items and draw(st.booleans()):
            del items[draw(st.integers(0, len(items) - 1)):]
        else:
            items += [draw(st.sampled_from(items or [0.0]))] * draw(st.integers(1, 3))
    elif kind == "add_key":
        mappings = [()] + [p for p in paths if isinstance(_parent(document, p)[p[-1]], dict)]
        where = draw(st.sampled_from(mappings))
        node = document if not where else _parent(document, where)[where[-1]]
        key = draw(keys)
        node[key] = draw(values)
        path = where + (key,)
    return document, path


def _set_argument(draw, document) -> str:
    """A random `--set key.path=value` from the scenario's real keys and invented ones."""
    real = [".".join(str(p) for p in path) for path in _paths(document) if all(isinstance(p, str) for p in path)] \
        if isinstance(document, dict) else []
    parts = draw(st.lists(st.sampled_from(INVENTED_KEYS[:11]) | st.sampled_from(["sim", "model", "pipeline", "law",
                                                                                  "reference", "checks", "initial"]),
                          min_size=1, max_size=3))
    key = draw(st.sampled_from(real) | st.just(".".join(parts))) if real else ".".join(parts)
    return f"{key}={draw(yaml_texts)}"


def _number(value):
    """`value` as a float if it is a finite positive number, else None."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    try:
        value = float(value)
    except OverflowError:  # an int beyond the float range
        return None
    return value if math.isfinite(value) and value > 0 else None


def _shorten(document, touched, periods: int) -> None:
    """Set sim.duration_s to `periods` trace periods, unless a mutation targeted it."""
    if not isinstance(document, dict) or not isinstance(document.get("sim"), dict):
        return
    if any(path[:2] == ("sim", "duration_s") or path == ("sim",) for path in touched if path):
        return
    sim = document["sim"]
    dt = _number(sim.get("dt_s", 0.002))
    control = _number(sim["control_period_s"]) if "control_period_s" in sim else dt
    trace = _number(sim["trace_period_s"]) if "trace_period_s" in sim else control
    period = trace or control or dt or 0.01
    sim["duration_s"] = periods * period


def _too_long(document) -> bool:
    """A run that would be valid but take more than MAX_STEPS physics steps (skipped, not run)."""
    if not isinstance(document, dict) or not isinstance(document.get("sim"), dict):
        return False
    sim = document["sim"]
    duration, dt = _number(sim.get("duration_s")), _number(sim.get("dt_s", 0.002))
    return duration is not None and dt is not None and MAX_STEPS < duration / dt <= 1.0000001e9


@st.composite
def hostile_inputs(draw, kinds):
    """(file bytes, extra argv) for one example."""
    if "bytes" in kinds and draw(st.integers(0, 9)) == 0:
        return draw(st.binary(max_size=400)), []
    name = draw(st.sampled_from(NAMES))
    document = copy.deepcopy(SCENARIOS[name])
    touched = []
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(st.sampled_from([k for k in kinds if k not in ("bytes", "set")]))
        document, path = _mutate(draw, document, kind)
        touched.append(path)
        if not isinstance(document, dict):
            break
    _shorten(document, touched, draw(st.integers(1, 6)))
    assume(not _too_long(document))
    overrides = []
    if "set" in kinds and draw(st.integers(0, 2)) == 0:  # a third of the examples
        for _ in range(draw(st.integers(1, 2))):
            overrides += ["--set", _set_argument(draw, document)]
    return _dump(document).encode("utf-8"), overrides


# --- the property -----------------------------------------------------------------------------

class Hang(BaseException):
    """An example that took longer than WATCHDOG_S (BaseException: no stage or library swallows it)."""


def _on_alarm(signum, frame):
    raise Hang(f"one example took more than {WATCHDOG_S} s")


def check_one(file_bytes: bytes, overrides: list[str], root: Path, capfd) -> int:
    """Run one mutated scenario and assert the exit-status contract; returns the status."""
    folder = Path(tempfile.mkdtemp(dir=root))
    try:
        scenario = folder / "scenario.yaml"
        scenario.write_bytes(file_bytes)
        out = folder / "x.rrd"
        capfd.readouterr()
        previous = signal.signal(signal.SIGALRM, _on_alarm)
        signal.setitimer(signal.ITIMER_REAL, WATCHDOG_S)
        try:
            code = main(["run", str(scenario), "--out", str(out), *overrides])
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)
        stdout, stderr = capfd.readouterr()
        assert "Traceback" not in stderr and "Traceback" not in stdout, stderr
        assert code in (0, 1, 2), (code, stdout[-500:], stderr[-500:])
        left = sorted(p.name for p in folder.iterdir())
        if code == 2:
            lines = stderr.splitlines()
            assert len(lines) == 1 and lines[0].startswith("error: "), stderr
            assert len(lines[0]) <= MAX_ERROR_LINE, f"{len(lines[0])} characters: {lines[0][:300]}"
            assert "x" * 100 not in lines[0], f"quotes more than ~80 characters of a value: {lines[0][:300]}"
            assert stdout == "", stdout
            assert left == ["scenario.yaml"], left
        else:
            assert stderr == "", stderr
            assert out.is_file(), left
            assert not [n for n in left if n.endswith(".partial")], left
            assert testbed.read(out).status in stdout.splitlines()[0], stdout
        return code
    finally:
        shutil.rmtree(folder, ignore_errors=True)


SETTINGS = dict(deadline=None, derandomize=True, database=None, print_blob=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow,
                                       HealthCheck.filter_too_much, HealthCheck.data_too_large])


@pytest.fixture
def fuzz_root(tmp_path, monkeypatch):
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    monkeypatch.chdir(cwd)  # nothing may land in the working directory either
    yield tmp_path
    assert list(cwd.iterdir()) == [], "a run wrote into the working directory"
    assert not (cwd / "MUJOCO_LOG.TXT").exists()


# Fast: type swaps, extreme numbers, deletions, wrong lengths, invented keys, non-mappings, random
# --set and random bytes are nearly all refused before anything runs (a few examples run for a
# few control periods).
@settings(max_examples=500, **SETTINGS)
@given(case=hostile_inputs(kinds=("replace", "extreme", "delete", "resize", "add_key", "non_mapping", "bytes",
                                  "set")))
def test_fuzz_mutated_scenarios_quick(case, fuzz_root, capfd):
    check_one(*case, fuzz_root, capfd)


# The suite's share of the long fuzz; `make fuzz` runs 3000 (about 2 min on a quiet machine).
# 600 examples took 171.8 s under load (0.29 s an example at load average 7-13 on 2 cores; some
# 136 s of CPU), the suite's longest test: the suite keeps 150 (34 s of CPU), the perturbations
# that run included. 150 took 85.7 s at load average 13-20 (0.57 s an example).
LONG_EXAMPLES = int(os.environ.get("TESTBED_FUZZ_EXAMPLES", "150"))


@pytest.mark.slow
@pytest.mark.timeout(max(300, 2 * LONG_EXAMPLES))  # 2 s an example: 3.5x the 0.57 s measured under load
@settings(max_examples=LONG_EXAMPLES, **SETTINGS)
@given(case=hostile_inputs(kinds=("replace", "extreme", "delete", "resize", "add_key", "non_mapping", "bytes", "set")
                           + ("perturb",) * 6))
def test_fuzz_mutated_scenarios(case, fuzz_root, capfd):
    check_one(*case, fuzz_root, capfd)
