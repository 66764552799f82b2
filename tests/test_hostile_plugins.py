"""Hostile plug-in stages (issue 23): whatever a stage raises (a BaseException, GeneratorExit, a
message that cannot be printed, sys.exit, os._exit), returns (a complex or text torque) or
prints, a run ends with status error and one bounded line naming the stage, exit 1; a campaign
gets that case's error row; `--json` keeps stdout for the JSON document; campaign workers
print no raw warning. A plug-in file is imported once per process: every test writes its own
(the law's name comes from its tmp_path)."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
import yaml

import testbed
from testbed.cli import main
from testbed.errors import ERROR_LIMIT

HOSTILE_LAW = '''
import os
import sys
import warnings
from dataclasses import dataclass

import numpy as np
import testbed

print("printed by the plug-in on import")


class Weird(BaseException):
    """A direct subclass of BaseException, not an Exception."""


class Unprintable(Exception):
    def __str__(self):
        raise RuntimeError("no message")


@dataclass
class Params:
    mode: str = testbed.param("ok")


@testbed.metric("{metric}", lambda scenario: scenario.stages["law"][0] == "{law}", uses=())
def exits(run):
    """0, or sys.exit(0) in mode metric_sys_exit."""
    if run.scenario.stages["law"][1].mode == "metric_sys_exit":
        sys.exit(0)
    return 0.0


@testbed.stage("law", "{law}", Params)
class Hostile:
    outputs = ("torque",)

    def __init__(self, params, ctx):
        self.mode = params.mode
        if self.mode == "init_raise":
            raise RuntimeError("no gain")
        if self.mode == "init_sys_exit":
            sys.exit(0)
        if self.mode == "init_os_exit":
            os._exit(0)

    def torque(self, t, estimate):
        mode = self.mode
        if mode == "print":
            print("printed by the stage")
            os.write(1, b"written to fd 1 by the stage\\n")
        if mode == "warn":
            warnings.warn("warned by the stage")
            np.array([1j]).astype(float)  # numpy's ComplexWarning
        if t >= 0.2:
            if mode == "base_exception":
                raise Weird("weird")
            if mode == "generator_exit":
                raise GeneratorExit("closed")
            if mode == "unprintable":
                raise Unprintable()
            if mode == "sys_exit":
                sys.exit(0)
            if mode == "os_exit":
                os._exit(0)
            if mode == "keyboard_interrupt":
                raise KeyboardInterrupt
            if mode == "long":
                raise RuntimeError("a line\\n" * 15000)  # 105 kB
            if mode == "complex":
                return {{"torque": np.array([1e-3j, 0, 0])}}
            if mode == "text":
                return {{"torque": ["1", "2", "3"]}}
        return {{"torque": np.zeros(3)}}
'''


class Hostile:
    """A hostile plug-in law in `folder`, its name unique to the folder, and scenarios using it."""

    def __init__(self, folder: Path):
        self.folder = folder
        suffix = abs(hash(str(folder))) % 10**8
        self.law, self.metric = f"hostile.law_{suffix}", f"hostile_exits_{suffix}"
        (folder / "hostile_law.py").write_text(HOSTILE_LAW.format(law=self.law, metric=self.metric))

    def scenario(self, mode: str = "ok", modes: list[str] | None = None, checks: dict | None = None) -> str:
        """A 0.5 s run of the law in `mode`; `modes`: a campaign of one case per mode."""
        data = {"name": "hostile", "plugins": ["hostile_law.py"], "model": {"system": "satellite"},
                "sim": {"duration_s": 0.5, "dt_s": 0.01},
                "pipeline": {"law": {"type": self.law, "mode": mode}, "allocator": {"type": "ideal_torque"}},
                "checks": checks or {}}
        if modes:
            data["sweep"] = {"grid": {"pipeline.law.mode": modes}}
        path = self.folder / f"{mode}{'_campaign' if modes else ''}.yaml"
        path.write_text(yaml.safe_dump(data))
        return str(path)

    def failed(self, reason: str) -> str:
        return f"stage law '{self.law}' failed at t = 0.2 s: {reason}"


def importing(plugin: str) -> str:
    """A scenario that only imports `plugin`."""
    return f"name: s\nplugins: [{plugin}]\nmodel: {{system: satellite}}\nsim: {{duration_s: 0.5, dt_s: 0.01}}\n"


@pytest.fixture
def hostile(tmp_path) -> Hostile:
    return Hostile(tmp_path)


def run_json(capfd, *argv) -> tuple[int, object, str]:
    """main(argv) with --json: (exit status, the JSON document stdout holds, stderr)."""
    capfd.readouterr()
    code = main([*map(str, argv), "--json"])
    out, err = capfd.readouterr()
    assert "Traceback" not in err, err
    return code, json.loads(out), err


@pytest.mark.parametrize("mode, reason", [
    ("base_exception", "Weird: weird"),
    ("generator_exit", "GeneratorExit: closed"),
    ("unprintable", "Unprintable (its message cannot be printed)"),
    ("sys_exit", "it exited the process (sys.exit(0))"),
    ("text", "key 'torque' is not numeric: ['1', '2', '3']"),
])
def test_a_stage_that_raises_anything_or_returns_text_fails_the_run(hostile, capfd, tmp_path, mode, reason):
    out = tmp_path / "x.rrd"
    code, result, _ = run_json(capfd, "run", hostile.scenario(mode), "--out", out)
    assert (code, result["status"], result["error"]) == (1, "error", hostile.failed(reason))
    assert testbed.read(out).error == hostile.failed(reason)  # the trace up to t = 0.19 s is kept


def test_a_complex_torque_fails_the_run(hostile, capfd, tmp_path):
    """float() of a complex array drops its imaginary part (with a warning main() ignores)."""
    code, result, _ = run_json(capfd, "run", hostile.scenario("complex"), "--out", tmp_path / "x.rrd")
    assert (code, result["status"]) == (1, "error")
    assert result["error"].startswith(hostile.failed("returned a complex 'torque': ")), result["error"]


def test_a_100_kB_multi_line_message_is_one_bounded_line(hostile, capfd, tmp_path):
    code, result, _ = run_json(capfd, "run", hostile.scenario("long"), "--out", tmp_path / "x.rrd")
    error = result["error"]
    assert (code, result["status"], len(error)) == (1, "error", ERROR_LIMIT)
    assert error.startswith(hostile.failed("RuntimeError: a line a line a line ")) and error.endswith("..."), error
    assert error.isprintable()


def test_a_metric_that_calls_sys_exit_fails_its_check(hostile, capfd, tmp_path):
    scenario = hostile.scenario("metric_sys_exit", checks={hostile.metric: {"max": 1}})
    code, result, _ = run_json(capfd, "run", scenario, "--out", tmp_path / "x.rrd")
    assert (code, result["status"]) == (1, "ok")
    assert [(c["name"], c["passed"], c["reason"]) for c in result["checks"]] == [
        (hostile.metric, False, "it exited the process (sys.exit(0))")]


@pytest.mark.parametrize("mode, reason", [("init_raise", "RuntimeError: no gain"),
                                          ("init_sys_exit", "it exited the process (sys.exit(0))")])
def test_a_stage_whose_constructor_fails_is_bad_input(hostile, capfd, tmp_path, mode, reason):
    out = tmp_path / "out" / "x.rrd"
    capfd.readouterr()
    assert main(["run", hostile.scenario(mode), "--out", str(out)]) == 2
    assert capfd.readouterr().err == f"error: pipeline.law: {hostile.law} cannot be built: {reason}\n"
    assert not (tmp_path / "out").exists()


def test_a_plugin_that_calls_sys_exit_on_import_is_bad_input(tmp_path, capfd):
    (tmp_path / "exits.py").write_text("x = 1\nraise SystemExit(0)\n")
    (tmp_path / "s.yaml").write_text(importing("exits.py"))
    capfd.readouterr()
    assert main(["run", str(tmp_path / "s.yaml"), "--out", str(tmp_path / "x.rrd")]) == 2
    assert capfd.readouterr().err == f"error: plugins[0]: {tmp_path / 'exits.py'}:2: it exited the process (sys.exit(0))\n"


def test_os_exit_in_a_plugin_is_contained_in_a_real_process(hostile, tmp_path):
    """In one process (os._exit would end it, status 0): a stage's tick, its constructor and a
    plug-in's import call os._exit(0); the run fails (1), the other two are bad input (2)."""
    (tmp_path / "exits_on_import.py").write_text("import os\nos._exit(0)\n")
    (tmp_path / "import.yaml").write_text(importing("exits_on_import.py"))
    argvs = [["run", hostile.scenario("os_exit"), "--out", str(tmp_path / "x.rrd"), "--json"],
             ["run", hostile.scenario("init_os_exit"), "--out", str(tmp_path / "y.rrd")],
             ["run", str(tmp_path / "import.yaml"), "--out", str(tmp_path / "z.rrd")]]
    script = "import json, sys\nfrom testbed.cli import main\nprint(json.dumps([main(a) for a in json.loads(sys.argv[1])]))"
    here = str(Path(testbed.__file__).parent.parent)  # this checkout's testbed, from any cwd
    done = subprocess.run([sys.executable, "-c", script, json.dumps(argvs)], cwd=tmp_path, capture_output=True,
                          text=True, timeout=180, env=os.environ | {"PYTHONPATH": here})
    assert done.returncode == 0, done.stderr
    document, statuses = done.stdout.splitlines()
    assert json.loads(statuses) == [1, 2, 2]
    assert json.loads(document)["error"] == hostile.failed("it exited the process (os._exit(0))")
    assert done.stderr.splitlines()[-2:] == [
        f"error: pipeline.law: {hostile.law} cannot be built: it exited the process (os._exit(0))",
        f"error: plugins[0]: {tmp_path / 'exits_on_import.py'}:2: it exited the process (os._exit(0))"]


GUARD_SCRIPT = textwrap.dedent("""\
    import importlib.util, os, sys, threading
    spec = importlib.util.spec_from_file_location("exit_guard", sys.argv[1])
    guard = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(guard)
    original = os._exit
    try:
        with guard.os_exit_raises():
            with guard.os_exit_raises():  # nested: the outer block restores
                pass
            os._exit(3)
    except guard.ExitCalled as exc:
        print("raised", exc.code, os._exit is original, flush=True)
    with guard.os_exit_raises():
        pid = os.fork()
        if pid == 0:
            os._exit(5)  # a forked child exits for real
        print("child", os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]), flush=True)
        threading.Thread(target=os._exit, args=(7,)).start()  # another thread exits for real
        threading.Event().wait(30)
    print("not reached")
    """)


def test_the_exit_guard_raises_only_in_its_own_thread_and_process(tmp_path):
    path = Path(testbed.__file__).with_name("exit_guard.py")
    done = subprocess.run([sys.executable, "-c", GUARD_SCRIPT, str(path)], capture_output=True, text=True, timeout=60)
    assert (done.returncode, done.stdout, done.stderr) == (7, "raised 3 True\nchild 5\n", "")


@pytest.mark.parametrize("argv", [["run", "{scenario}", "--out", "{tmp}/x.rrd"],
                                  ["check", "{scenario}", "--out-dir", "{tmp}"],
                                  ["sweep", "{campaign}", "--case", "0", "--out", "{tmp}/sweep"]],
                         ids=["run", "check", "sweep --case"])
def test_with_json_a_stages_output_goes_to_stderr(hostile, capfd, tmp_path, argv):
    """--json: stdout parses as one document, and what the plug-in wrote is on stderr; without
    --json it stays on stdout (the plug-in is imported once: its import's line is not repeated)."""
    names = {"scenario": hostile.scenario("print"), "campaign": hostile.scenario("print", modes=["print"]),
             "tmp": tmp_path}
    argv = [a.format(**names) for a in argv]
    code, document, err = run_json(capfd, *argv)
    assert code == 0, document
    for line in ("printed by the plug-in on import", "printed by the stage", "written to fd 1 by the stage"):
        assert line in err.splitlines(), err[-500:]
    assert main(argv) == 0
    out = capfd.readouterr().out.splitlines()
    assert out.count("printed by the stage") == 50 and out.count("written to fd 1 by the stage") == 50


def test_a_campaign_turns_every_hostile_stage_into_its_error_row(hostile, capfd, tmp_path):
    """One worker process runs every case: a stage that exits its process or raises a
    KeyboardInterrupt there costs its own row, not the worker; stdout holds only the JSON."""
    expected = {"ok": "", "print": "", "warn": "",
                "base_exception": hostile.failed("Weird: weird"),
                "keyboard_interrupt": hostile.failed("KeyboardInterrupt"),
                "sys_exit": hostile.failed("it exited the process (sys.exit(0))"),
                "os_exit": hostile.failed("it exited the process (os._exit(0))"),
                "unprintable": hostile.failed("Unprintable (its message cannot be printed)")}
    campaign = hostile.scenario("ok", modes=list(expected))
    # its own process: the workers are forked from multiprocessing's fork server, which keeps the
    # stdout of the process that started it (a campaign run earlier in this one, by another test)
    done = subprocess.run([sys.executable, "-m", "testbed", "campaign", str(campaign), "--workers", "1",
                           "--out", str(tmp_path / "out"), "--json"], capture_output=True, text=True, timeout=240)
    code, rows, err = done.returncode, json.loads(done.stdout), done.stderr
    assert "Traceback" not in err, err
    assert code == 1
    assert {r["pipeline.law.mode"]: r["error"] for r in rows} == expected
    assert [r["status"] for r in rows] == ["ok"] * 3 + ["error"] * 5
    with open(tmp_path / "out" / "hostile.csv", newline="") as handle:
        assert {r["pipeline.law.mode"]: r["error"] for r in csv.DictReader(handle)} == expected
    assert "printed by the stage" in err.splitlines()  # from the worker process
    assert "Warning" not in err and "warned by the stage" not in err, err[-1000:]


def test_plugin_code_outside_a_stage_that_exits_is_a_failed_command(capfd):
    """A registered subcommand (as a system package adds one) that calls sys.exit(0): exit 1 and
    one line, not the plug-in's own status 0 as if the command had passed."""
    import sys as _sys

    from testbed import registry
    from testbed.cli.commands import command
    from testbed.plugins import discover

    discover()  # the built-ins are in the snapshot restored after
    saved = registry.snapshot()
    try:
        @command("test-exits")
        def add_parser(sub):
            sub.add_parser("test-exits").set_defaults(func=lambda args: _sys.exit(0))

        assert main(["test-exits"]) == 1
    finally:
        registry.restore(saved)
    out, err = capfd.readouterr()
    assert out == "" and err.splitlines() == ["error: plug-in code exited the process (sys.exit(0))"]
