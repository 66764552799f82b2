"""The package's layout holds: no import cycle, shared machinery that names no system, and a
new system or stage that is one folder or one file with no edit to any shared file."""

from __future__ import annotations

import ast
import io
import os
import re
import shutil
import subprocess
import sys
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "testbed"
SYSTEM_WORDS = re.compile(r"planar|gyrostat|cmg|rhombus|lebedev|akor", re.IGNORECASE)


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def import_graph() -> dict[str, set[str]]:
    """module -> the package modules it imports (any `import` or `from ... import` statement,
    at module level or inside functions, absolute or relative)."""
    modules = {module_name(p): p for p in PACKAGE.rglob("*.py")}
    graph = {}
    for name, path in modules.items():
        targets = set()
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                candidates = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    base = ".".join(package.split(".")[: len(package.split(".")) - node.level + 1] + ([base] if base else []))
                candidates = [base] + [f"{base}.{a.name}" for a in node.names]
            else:
                continue
            for c in candidates:
                # importing a.b.c imports a and a.b too; only a module's parents that are not
                # its own ancestors count as edges
                while c and c not in modules:
                    c = c.rpartition(".")[0]
                if c and c != name and not name.startswith(c + "."):
                    targets.add(c)
        graph[name] = targets
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on_stack, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                out.append(sorted(component))

    for v in graph:
        if v not in index:
            visit(v)
    return out


def test_the_package_has_no_import_cycle():
    graph = import_graph()
    assert len(graph) > 40 and graph["testbed.runner"]  # the walk found the package and its imports
    assert cycles(graph) == []


def test_the_cycle_finder_finds_a_cycle():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def code_without_docs(path: Path) -> str:
    """The source with comments and docstrings removed (names and string literals kept)."""
    tree = ast.parse(path.read_text())
    docstrings = {id(n.body[0].value) for n in ast.walk(tree)
                  if isinstance(n, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
                  and n.body and isinstance(n.body[0], ast.Expr) and isinstance(n.body[0].value, ast.Constant)
                  and isinstance(n.body[0].value.value, str)}
    doc_lines = set()
    for n in ast.walk(tree):
        if isinstance(n, ast.Constant) and id(n) in docstrings:
            doc_lines.update(range(n.lineno, n.end_lineno + 1))
    kept = []
    for tok in tokenize.generate_tokens(io.StringIO(path.read_text()).readline):
        if tok.type == tokenize.COMMENT or tok.start[0] in doc_lines:
            continue
        kept.append(tok.string)
    return " ".join(kept)


# Shared machinery: the top level and the folders every system and method runs on. The method
# folders (lebedev/, steering/, guidance/, stages/) and systems/ may name the systems they serve;
# the registries and the free bus that sit in systems/ and references/ may not.
SHARED_FOLDERS = ("math", "campaign", "recording", "cli", "scenario", "stepping")
CORE = (sorted(PACKAGE.glob("*.py")) + [p for f in SHARED_FOLDERS for p in sorted((PACKAGE / f).glob("*.py"))]
        + [PACKAGE / "systems" / "registry.py", PACKAGE / "systems" / "free_bus.py", PACKAGE / "references" / "registry.py"])


def test_the_top_level_holds_at_most_twelve_modules():
    assert len(list(PACKAGE.glob("*.py"))) <= 12, sorted(p.name for p in PACKAGE.glob("*.py"))


@pytest.mark.parametrize("path", CORE, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_shared_machinery_names_no_system(path):
    found = SYSTEM_WORDS.findall(code_without_docs(path))
    assert not found, f"{path.relative_to(ROOT)} names {sorted(set(found))} outside its docs"


def test_every_system_folder_registers_its_own_system_and_has_its_model():
    from testbed.plugins import discover
    from testbed.systems.registry import SYSTEMS

    discover()
    folders = sorted(p.name for p in (PACKAGE / "systems").iterdir() if (p / "__init__.py").is_file())
    assert SYSTEMS.names() == folders
    for name in folders:
        assert (ROOT / "models" / f"{name}.xml").is_file()
        assert SYSTEMS[name].make_plant.__module__.startswith(f"testbed.systems.{name}")



def test_every_subcommand_registers_one_way_in_the_module_that_implements_it():
    from testbed.cli.commands import COMMANDS
    from testbed.cli.dispatch import BUILT_IN_COMMANDS
    from testbed.plugins import discover

    discover()
    assert {name: add_parser.__module__ for name, add_parser in COMMANDS.items()} == {
        "run": "testbed.cli.run", "check": "testbed.cli.run", "list": "testbed.cli.list_scenarios",
        "inspect": "testbed.cli.inspect_trace", "sweep": "testbed.cli.campaign", "describe": "testbed.cli.describe",
        "init": "testbed.cli.init", "envelope": "testbed.systems.cmg_cluster.envelope_command"}
    assert {m.__name__ for m in BUILT_IN_COMMANDS} == {add_parser.__module__ for _, add_parser in COMMANDS.items()
                                                       if add_parser.__module__.startswith("testbed.cli.")}

NEW_SYSTEM = '''"""A second rigid bus, to prove that a system is one folder and one MJCF file."""
from dataclasses import dataclass

from testbed.systems.free_bus import FreeBus, set_bus_mass
from testbed.scenario.shipped_files import load_spec
from testbed.plant import Plant
from testbed.scenario.schema import param
from testbed.systems.registry import system


@dataclass(kw_only=True)
class Params:
    system: str = "twin_bus"
    inertia_kg_m2: list[float] = param([300.0, 500.0, 600.0], length=3)
    mass_kg: float = param(50.0, gt=0)


@system("twin_bus", Params)
def make_plant(params, sim):
    spec = load_spec("twin_bus.xml", sim.dt_s, sim.integrator)
    set_bus_mass(spec, params.inertia_kg_m2, params.mass_kg)
    return Plant(FreeBus(spec.compile()))
'''

NEW_STAGE = '''"""A constant body torque, to prove that a generic stage is one file."""
from dataclasses import dataclass

import numpy as np

from testbed.pipeline import stage
from testbed.scenario.schema import param


@dataclass(kw_only=True)
class ConstantParams:
    torque_nm: list[float] = param(length=3)


@stage("law", "constant_torque", ConstantParams)
class ConstantTorque:
    def __init__(self, params, ctx):
        self.value = np.asarray(params.torque_nm, float)

    def torque(self, t, estimate):
        return {"torque": self.value}
'''

SCENARIO = """name: twin
model: {system: twin_bus, inertia_kg_m2: [300, 500, 600]}
sim: {duration_s: 10, dt_s: 0.01}
pipeline:
  law: {type: constant_torque, torque_nm: [0, 2, 0]}
  allocator: {type: ideal_torque}
checks:
  final_omega_rad_s: {max: 1}
"""


@pytest.mark.slow
def test_a_new_system_and_a_new_stage_need_no_edit_to_a_shared_file(tmp_path):
    """Copy the project, add models/twin_bus.xml, one system folder and one stage file, and run
    them: I w' = M from rest about a principal axis gives |w(T)| = M T / I (2 * 10 / 500)."""
    copy = tmp_path / "project"
    shutil.copytree(PACKAGE, copy / "testbed", symlinks=True, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(ROOT / "models", copy / "models")
    before = {p.relative_to(copy): p.read_bytes() for p in copy.rglob("*") if p.is_file()}
    shutil.copy(ROOT / "models" / "satellite.xml", copy / "models" / "twin_bus.xml")
    (copy / "testbed" / "systems" / "twin_bus").mkdir()
    (copy / "testbed" / "systems" / "twin_bus" / "__init__.py").write_text(NEW_SYSTEM)
    (copy / "testbed" / "stages" / "constant_torque.py").write_text(NEW_STAGE)
    (copy / "twin.yaml").write_text(SCENARIO)
    after = {p.relative_to(copy): p.read_bytes() for p in copy.rglob("*") if p.is_file()}
    assert all(after[p] == content for p, content in before.items())  # nothing shared edited
    env = dict(os.environ, PYTHONPATH=str(copy))
    done = subprocess.run([sys.executable, "-m", "testbed", "run", "twin.yaml", "--json", "--out", "twin.rrd"],
                          cwd=copy, env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    import json

    result = json.loads(done.stdout)
    assert result["metrics"]["final_omega_rad_s"] == pytest.approx(2.0 * 10.0 / 500.0, rel=1e-12)
