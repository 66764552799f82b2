"""The package as a user installs it (`pip install .`, not editable): the wheel carries the MJCF
models and the scenario files, and the installed `testbed` lists and runs the shipped scenarios
from any directory, without the checkout.

The wheel is built offline (--no-build-isolation --no-index, from a copy of the checkout so the
tree gets no build/ folder) and installed with `pip install --target` into a temporary folder
that is put first on PYTHONPATH; the tests assert that the code and the data really come from
there and not from the editable install in .venv.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "testbed"
MODELS = sorted(p.name for p in (ROOT / "models").glob("*.xml"))
SCENARIOS = sorted(p.name for p in (ROOT / "scenarios").glob("*.yaml"))
# not part of a build: the venv, git, outputs, caches, earlier builds
NOT_SOURCES = shutil.ignore_patterns(".venv", ".git", ".ci", ".pytest_cache", "runs", "build", "dist", "*.egg-info",
                                     "__pycache__", "*.rrd", "*.rrd.partial", "MUJOCO_LOG.TXT")


def _pip(*args: str, cwd: Path) -> None:
    env = dict(os.environ, PIP_DISABLE_PIP_VERSION_CHECK="1", PIP_NO_INPUT="1")
    done = subprocess.run([sys.executable, "-m", "pip", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, f"pip {' '.join(args)}:\n{done.stdout}\n{done.stderr}"


def test_the_package_links_to_the_top_level_models_and_scenarios():
    """testbed/models and testbed/scenarios are the repository's folders (links), not copies."""
    for name in ("models", "scenarios"):
        link = ROOT / "testbed" / name
        assert link.is_symlink() and link.resolve() == (ROOT / name).resolve()


def test_list_without_scenario_files_is_bad_input(tmp_path, monkeypatch, capsys):
    from testbed.scenario import shipped_files
    from testbed.cli import main

    monkeypatch.setattr(shipped_files, "SCENARIO_DIR", tmp_path)
    assert main(["list"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert len(captured.err.splitlines()) == 1 and str(tmp_path) in captured.err


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(wheel, install folder, an empty working folder outside the checkout)."""
    base = tmp_path_factory.mktemp("install")
    source, wheels, target, work = base / "source", base / "wheels", base / "site", base / "work"
    shutil.copytree(ROOT, source, ignore=NOT_SOURCES)
    _pip("wheel", "--no-deps", "--no-build-isolation", "--no-index", "-w", str(wheels), str(source), cwd=base)
    (wheel,) = wheels.glob("*.whl")
    _pip("install", "--no-deps", "--no-index", "--target", str(target), str(wheel), cwd=base)
    work.mkdir()
    return wheel, target, work


def _in_install(target: Path, work: Path, *argv: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(target))
    env.pop("PYTHONHOME", None)
    return subprocess.run(list(argv), cwd=work, env=env, capture_output=True, text=True, timeout=120)


@pytest.mark.slow
def test_the_wheel_carries_the_models_the_scenarios_and_every_module(installed):
    wheel, _, _ = installed
    names = set(zipfile.ZipFile(wheel).namelist())
    assert {f"testbed/models/{m}" for m in MODELS} <= names
    assert {f"testbed/scenarios/{s}" for s in SCENARIOS} <= names
    modules = {p.relative_to(ROOT).as_posix() for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts}
    assert modules <= names
    assert not any(n.split("/")[0] in ("models", "scenarios") for n in names)  # nothing loose in site-packages


@pytest.mark.slow
def test_the_installed_package_is_the_wheel_not_the_checkout(installed):
    _, target, work = installed
    probe = ("import testbed, testbed.scenario.shipped_files as s; "
             "print(testbed.__file__); print(s.MODELS_DIR); print(s.SCENARIO_DIR)")
    done = _in_install(target, work, sys.executable, "-c", probe)
    assert done.returncode == 0, done.stderr
    package_file, models_dir, scenario_dir = (Path(line) for line in done.stdout.splitlines())
    assert package_file == target.resolve() / "testbed" / "__init__.py"
    assert models_dir == target.resolve() / "testbed" / "models"
    assert scenario_dir == target.resolve() / "testbed" / "scenarios"


@pytest.mark.slow
def test_installed_list_names_every_shipped_scenario(installed):
    _, target, work = installed
    done = _in_install(target, work, str(target / "bin" / "testbed"), "list")
    assert done.returncode == 0, done.stderr
    assert [line.split()[0] for line in done.stdout.splitlines()] == [Path(s).stem for s in SCENARIOS]


@pytest.mark.slow
def test_installed_run_loads_its_model_and_writes_the_trace(installed):
    _, target, work = installed
    done = _in_install(target, work, str(target / "bin" / "testbed"),
                       "run", "cmg_open_loop", "--set", "sim.duration_s=1", "--out", "x.rrd")
    assert done.returncode == 0, done.stdout + done.stderr
    assert (work / "x.rrd").stat().st_size > 0


@pytest.mark.slow
@pytest.mark.parametrize("example", ["pd_steering", "star_tracker"])
def test_installed_testbed_runs_the_examples_and_their_plugins(installed, example):
    """An example (a plug-in file and its scenario, outside the package) run by the installed
    wheel from another directory, shortened; its checks need not hold that early: exit 0 or 1."""
    _, target, work = installed
    scenario = ROOT / "examples" / f"{example}.yaml"
    done = _in_install(target, work, str(target / "bin" / "testbed"), "run", str(scenario),
                       "--set", "sim.duration_s=5", "--out", f"{example}.rrd", "--json")
    assert done.returncode in (0, 1), done.stderr
    assert json.loads(done.stdout)["status"] == "ok"
    assert (work / f"{example}.rrd").stat().st_size > 0
