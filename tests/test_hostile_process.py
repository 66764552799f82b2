"""Plug-in code that meddles with the command's own process (issue 23, second hostile round):
a fork, a signal taken or set off, a thread or an atexit handler that never ends, a changed
folder or stdout. Each ends as the command's contract says: one line, its exit status, the
trace where it was named or none, and a process that ends within EXIT_BOUND_S of its command.

Each test runs `python -m testbed run` in a subprocess on the satellite for a second or two,
with a plug-in law that does at import (HOSTILE_IMPORT) and at its first tick (HOSTILE_TICK)
what the test says.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from testbed.cli import EXIT_BOUND_S

PLUGIN = '''
import atexit, os, signal, sys, threading, time
from dataclasses import dataclass
import numpy as np
import testbed

IMPORT = os.environ.get("HOSTILE_IMPORT", "")
if IMPORT == "thread":
    threading.Thread(target=lambda: time.sleep(10**6)).start()        # not a daemon
if IMPORT == "atexit_sleep":
    atexit.register(lambda: time.sleep(10**6))
if IMPORT == "atexit_raise":
    atexit.register(lambda: 1 / 0)
if IMPORT == "stdout_none":
    sys.stdout = None
if IMPORT == "chdir":
    os.chdir("/")
if IMPORT == "alarm":
    signal.alarm(1)


@dataclass
class Params:
    gain: float = testbed.param(0.0)


@testbed.stage("law", "hostile_process.law", Params)
class Law:
    outputs = ("torque",)

    def __init__(self, params, ctx):
        self.ticks = 0

    def torque(self, t, estimate):
        self.ticks += 1
        tick = os.environ.get("HOSTILE_TICK", "")
        if tick == "fork" and self.ticks == 1:
            if os.fork() == 0:
                os._exit(0)
        if tick == "ignore_sigint" and self.ticks == 1:
            signal.signal(signal.SIGINT, signal.SIG_IGN)
        return {"torque": np.zeros(3)}
'''


def scenario(folder: Path, duration_s: float) -> Path:
    (folder / "hostile_process.py").write_text(PLUGIN)
    data = {"name": "hostile_process", "plugins": ["hostile_process.py"], "model": {"system": "satellite"},
            "sim": {"duration_s": duration_s, "dt_s": 0.01},
            "pipeline": {"law": {"type": "hostile_process.law"}, "allocator": {"type": "ideal_torque"}}, "checks": {}}
    path = folder / "s.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def run(folder: Path, env: dict, duration_s: float = 1.0, timeout: float = 90):
    """(exit status, stdout, stderr) of `testbed run s.yaml --out t.rrd` in `folder`."""
    path = scenario(folder, duration_s)
    proc = subprocess.run([sys.executable, "-m", "testbed", "run", str(path), "--out", "t.rrd"], cwd=folder,
                          capture_output=True, text=True, timeout=timeout, env=os.environ | env)
    return proc.returncode, proc.stdout, proc.stderr


def files(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name not in ("s.yaml", "hostile_process.py", "__pycache__"))


@pytest.mark.parametrize("mode", ["thread", "atexit_sleep"])
def test_plugin_code_that_keeps_the_process_alive_is_ended_after_its_command(tmp_path, mode):
    """Before: the run finished and the process never ended."""
    code, out, err = run(tmp_path, {"HOSTILE_IMPORT": mode})
    assert code == 0 and "scenario hostile_process: ok" in out, err
    assert err.splitlines() == [f"note: plug-in code kept the process from ending; ended it "
                                f"{EXIT_BOUND_S:g} s after the command"]
    assert files(tmp_path) == ["t.rrd"]


def test_an_atexit_handler_that_raises_costs_one_line(tmp_path):
    """Before: Python's 'Exception ignored in atexit callback' and a traceback."""
    code, out, err = run(tmp_path, {"HOSTILE_IMPORT": "atexit_raise"})
    assert code == 0 and "Traceback" not in err, err
    assert err.splitlines() == ["warning: Exception ignored in atexit callback: ZeroDivisionError: division by zero"]


def test_a_plugin_that_sets_stdout_to_none_does_not_silence_the_command(tmp_path):
    """Before: AttributeError: 'NoneType' object has no attribute 'flush', with a traceback."""
    code, out, err = run(tmp_path, {"HOSTILE_IMPORT": "stdout_none"})
    assert (code, err) == (0, "")
    assert "scenario hostile_process: ok" in out


def test_a_plugin_that_changes_folder_at_import_leaves_the_trace_where_it_was_named(tmp_path):
    """Before: the trace was written to /t.rrd."""
    code, out, err = run(tmp_path, {"HOSTILE_IMPORT": "chdir"})
    assert (code, err) == (0, ""), err
    assert files(tmp_path) == ["t.rrd"] and not Path("/t.rrd").exists()


def test_a_plugin_alarm_ends_the_run_in_one_line_with_no_trace_left(tmp_path):
    """signal.alarm(1) at import, a run of several seconds: SIGALRM ends it as SIGTERM would,
    exit 128 + 14 (before: killed by the signal, its .partial trace left behind)."""
    code, out, err = run(tmp_path, {"HOSTILE_IMPORT": "alarm"}, duration_s=3000)
    assert code == 128 + signal.SIGALRM, (code, err)
    assert err.splitlines() == ["terminated by SIGALRM"]
    assert files(tmp_path) == []


@pytest.mark.parametrize("mode, why", [
    ("fork", "os.fork() in plug-in code: the run's process may not be forked"),
    ("ignore_sigint", "signal.signal(SIGINT, ...) in plug-in code: SIGINT and SIGTERM end the command (130, 143)")])
def test_a_stage_that_forks_or_takes_sigint_fails_its_run(tmp_path, mode, why):
    """Before: a fork left children simulating and the run hung; SIG_IGN took Ctrl-C away."""
    code, out, err = run(tmp_path, {"HOSTILE_TICK": mode})
    assert code == 1, (code, err)
    assert f"PluginRefused: {why}" in out and "Traceback" not in err, (out, err)
    assert files(tmp_path) == ["t.rrd"]  # the trace up to the failing tick, as for any stage failure


@pytest.mark.parametrize("sig", [signal.SIGXCPU, signal.SIGVTALRM, signal.SIGQUIT])
def test_another_signal_that_would_end_the_run_ends_it_in_one_line(tmp_path, sig):
    """SIGXCPU (`ulimit -t`), SIGVTALRM, SIGQUIT (Ctrl-\\) in the middle of a run: one line, exit
    128 + n, no .partial left (before: killed by it, the .partial left behind)."""
    path = scenario(tmp_path, 3000)
    proc = subprocess.Popen([sys.executable, "-m", "testbed", "run", str(path), "--out", "t.rrd"], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    start = time.monotonic()
    while not list(tmp_path.glob(".t.rrd.*.partial")) and proc.poll() is None and time.monotonic() - start < 60:
        time.sleep(0.02)
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 128 + sig, (proc.returncode, err)
    assert err.splitlines() == [f"terminated by {signal.Signals(sig).name}"]
    assert files(tmp_path) == []


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_after_the_command_ends_the_process_with_the_commands_status(tmp_path, sig):
    """Plug-in code holds the exit (an atexit handler that sleeps); a signal once the command
    has printed its result ends the process at once, with the command's own status 0 and its
    output whole. Before: the handler's KeyboardInterrupt or the signal itself ended it."""
    path = scenario(tmp_path, 1.0)
    proc = subprocess.Popen([sys.executable, "-m", "testbed", "run", str(path), "--out", "t.rrd"], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=os.environ | {"HOSTILE_IMPORT": "atexit_sleep", "PYTHONUNBUFFERED": "1"})
    lines = []
    for line in proc.stdout:  # the run's last line names its trace; the command returns right after
        lines.append(line)
        if line.startswith("trace:"):
            break
    time.sleep(2.0)  # from its last print to its return the command takes microseconds
    proc.send_signal(sig)
    rest, err = proc.communicate(timeout=60)
    out = "".join(lines) + rest
    assert proc.returncode == 0, (proc.returncode, err)
    assert "scenario hostile_process: ok" in out and "Traceback" not in err, err
    assert "kept the process from ending" not in err  # ended by the signal, before the 10 s bound
