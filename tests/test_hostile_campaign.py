"""Hostile campaigns and plug-ins against the engine (issue 23): nothing waits forever, nothing
crashes with a traceback, every signal ends the command with its status (README "Exit status").

Each campaign is a few cases of half a second simulated on the satellite with a plug-in law
(HOSTILE_LAW) that, by its `mode`, runs normally, sleeps forever, crashes its process or sends it
a signal, so a test chooses by a case value which cases misbehave.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import psutil
import pytest
import yaml

from campaign_cases import hand_started_cluster
from testbed.campaign.cluster import SCHEDULER_TIMEOUT_S, max_workers
from testbed.cli import main

HOSTILE_LAW = '''"""A zero-torque law that misbehaves at its first tick as its mode says."""
import os
import signal
import time
from dataclasses import dataclass

import numpy as np

from testbed.pipeline import stage
from testbed.scenario.schema import param

MIXED = ("crash", "sigterm", "sigint")  # mode "mixed": by tag // 3


@dataclass(kw_only=True)
class Params:
    tag: int = param(0)
    mode: str = param("ok")          # ok | hang | crash | sigint | sigterm | chdir | mixed
    misbehave_if_tag_mod3: int = param(-1)  # misbehave only when tag % 3 equals this (-1: always)


@stage("law", "hostile.law", Params)
class HostileLaw:
    def __init__(self, params, ctx):
        self.params = params

    def torque(self, t, estimate):
        p = self.params
        if p.misbehave_if_tag_mod3 in (-1, p.tag % 3):
            mode = MIXED[p.tag // 3 % 3] if p.mode == "mixed" else p.mode
            if mode == "hang":
                while True:
                    time.sleep(0.05)
            if mode == "crash":  # os._exit would only fail the case (testbed/exit_guard.py)
                os.abort()
            if mode == "chdir":  # to the plug-in's own folder: the worker's cwd is elsewhere from now on
                os.chdir(os.path.dirname(os.path.abspath(__file__)))
            if mode in ("sigint", "sigterm"):
                os.kill(os.getpid(), signal.SIGINT if mode == "sigint" else signal.SIGTERM)
                time.sleep(1)  # the signal is delivered meanwhile
        return {"torque": np.zeros(3)}
'''


PLUGIN = {}  # the one plug-in file of the session (a plug-in is imported once per process)


# Imports in this process; in a worker started with REFUSING_WORKER set it fails.
WORKER_REFUSED = '''import os
import testbed
if os.environ.get("REFUSING_WORKER"):
    raise RuntimeError("this worker refuses the plug-in")
'''


@pytest.fixture(scope="session", autouse=True)
def hostile_law(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("plugin") / "hostile_law.py"
    path.write_text(HOSTILE_LAW)
    (path.parent / "worker_refused.py").write_text(WORKER_REFUSED)
    PLUGIN["path"] = path
    return path


def campaign(tags: int = 2, mode: str = "ok", plugin: str | None = None, **law) -> dict:
    return {"name": "hostile", "plugins": [plugin or str(PLUGIN["path"])], "model": {"system": "satellite"},
            "sim": {"duration_s": 0.5, "dt_s": 0.01},
            "pipeline": {"law": {"type": "hostile.law", "mode": mode, **law}, "allocator": {"type": "ideal_torque"}},
            "checks": {}, "sweep": {"grid": {"pipeline.law.tag": list(range(tags))}}}


@pytest.fixture
def folder(tmp_path) -> Path:
    """Where a test writes its campaign file and its output."""
    return tmp_path


def write(folder: Path, data: dict) -> Path:
    path = folder / "campaign.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def error_lines(err: str) -> list[str]:
    return [line for line in err.splitlines() if line.strip()]


# --- --workers: bounded ---------------------------------------------------------------------

@pytest.mark.parametrize("workers", ["0", str(max_workers() + 1), "99999999999999999999"])
def test_workers_beyond_the_cap_are_refused(folder, capfd, workers):
    assert main(["sweep", str(write(folder, campaign())), "--workers", workers, "--out", str(folder / "out")]) == 2
    err = error_lines(capfd.readouterr().err)
    assert len(err) == 1 and err[0].startswith(f"error: --workers: must be 1 ... {max_workers()} "), err
    assert not (folder / "out").exists()


def test_more_workers_than_cases_start_one_per_case_with_a_note(folder, capfd):
    asked = min(3, max_workers())
    assert main(["sweep", str(write(folder, campaign(tags=2))), "--workers", str(asked), "--out", str(folder / "out")]) == 0
    out, err = capfd.readouterr()
    assert error_lines(err) == [f"note: --workers {asked} for 2 cases: started 2"]
    assert "2 cases, 2 passed, 0 failed" in out


def test_a_worker_that_does_not_start_is_one_error_line(folder, capfd, monkeypatch):
    import testbed.campaign.cluster

    monkeypatch.setattr(testbed.campaign.cluster, "START_TIMEOUT_S", 0.001)  # no worker starts that fast
    assert main(["sweep", str(write(folder, campaign())), "--workers", "1", "--out", str(folder / "out")]) == 2
    err = error_lines(capfd.readouterr().err)
    assert len(err) == 1 and err[0].startswith("error: --workers: the local cluster of 1 worker processes did not start"), err
    assert not (folder / "out").exists()


# --- --scheduler: a port that accepts and never answers ---------------------------------------

def test_a_scheduler_port_that_never_answers_is_refused_within_its_bound(folder, capfd):
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen()
    accepted = []

    def accept_and_say_nothing():
        while True:
            try:
                accepted.append(listener.accept()[0])
            except OSError:  # closed at the end of the test
                return

    threading.Thread(target=accept_and_say_nothing, daemon=True).start()
    address = f"tcp://127.0.0.1:{listener.getsockname()[1]}"
    path = str(write(folder, campaign()))
    try:
        code = main(["sweep", path, "--scheduler", address, "--out", str(folder / "out")])
    finally:
        listener.close()
        for connection in accepted:
            connection.close()
    err = error_lines(capfd.readouterr().err)
    assert code == 2 and len(err) == 1, err
    assert err[0].startswith("error: --scheduler: no Dask scheduler answers at ") and address in err[0]
    assert accepted, "the command never connected"
    assert not (folder / "out").exists()


# --- signals while the cluster starts -----------------------------------------------------------

def _cluster_processes(pid: int) -> list:
    """The command's children that multiprocessing started (fork server, resource tracker, workers)."""
    try:
        return [c for c in psutil.Process(pid).children(recursive=True) if "multiprocessing" in " ".join(c.cmdline())]
    except psutil.Error:
        return []


def _group_members(pgid: int) -> list[int]:
    members = []
    for process in psutil.process_iter():
        try:
            if os.getpgid(process.pid) == pgid:
                members.append(process.pid)
        except (ProcessLookupError, psutil.Error):
            continue
    return members


@pytest.mark.parametrize("sig, to_group, delay_s, code", [
    pytest.param(signal.SIGINT, True, 0.3, 130, id="ctrl-c-0.3s"),
    pytest.param(signal.SIGINT, True, 0.8, 130, id="ctrl-c-0.8s", marks=pytest.mark.slow),
    pytest.param(signal.SIGINT, True, 1.5, 130, id="ctrl-c-1.5s", marks=pytest.mark.slow),
    pytest.param(signal.SIGTERM, False, 0.8, 143, id="sigterm-0.8s")])
def test_a_signal_while_the_cluster_starts(folder, sig, to_group, delay_s, code):
    """Ctrl-C (SIGINT to the whole process group, as a terminal sends it) or SIGTERM (to the
    command) `delay_s` after the command's first multiprocessing child appeared: the command's
    own status and line, no traceback from distributed or a worker, no process left. (The cases
    hang: a signal that comes once the cluster is up stops a campaign that cannot end by itself.)"""
    proc = subprocess.Popen([sys.executable, "-m", "testbed", "sweep", str(write(folder, campaign(mode="hang"))),
                             "--workers", "2", "--out", str(folder / "out")], cwd=folder, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while not _cluster_processes(proc.pid):
            assert proc.poll() is None and time.monotonic() < deadline, "the cluster never started"
            time.sleep(0.02)
        time.sleep(delay_s)
        os.killpg(proc.pid, sig) if to_group else proc.send_signal(sig)
        _, err = proc.communicate(timeout=120)
        deadline = time.monotonic() + 30
        while _group_members(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.1)
        left = _group_members(proc.pid)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert "Traceback" not in err and "Error" not in err, err
    assert proc.returncode == code, err
    *before, last = error_lines(err)
    assert last == ("interrupted" if sig == signal.SIGINT else "terminated"), err
    assert all(line.startswith("stopped: 0 of 2 cases finished") for line in before), err
    assert left == [], "processes left behind"


def rows_of(folder: Path) -> list[dict]:
    import csv

    with open(folder / "out" / "hostile.csv", newline="") as handle:
        return list(csv.DictReader(handle))


# --- a case that changes its worker's cwd --------------------------------------------------------

def test_a_case_that_changes_its_workers_cwd_sends_no_other_case_elsewhere(folder, capfd, monkeypatch, hostile_law):
    """#13: case 0 moves its worker's cwd to the plug-in's folder; case 1 then runs in the same
    worker. With a relative --out, both traces and the table stay in ./out (resolved once, in
    the command), nothing lands in ./out below the case's new cwd."""
    monkeypatch.chdir(folder)
    path = write(folder, campaign(tags=2, mode="chdir", misbehave_if_tag_mod3=0))
    code = main(["sweep", str(path), "--workers", "1", "--out", "out", "--rrd"])
    out, err = capfd.readouterr()
    assert code == 0 and "Traceback" not in err, err
    assert [(r["status"], r["error"]) for r in rows_of(folder)] == [("ok", ""), ("ok", "")]
    assert sorted(p.name for p in (folder / "out").glob("case*.rrd")) == ["case0000.rrd", "case0001.rrd"]
    assert not (hostile_law.parent / "out").exists()


# --- a case that runs forever -----------------------------------------------------------------

def test_a_case_that_runs_forever_is_given_up_twice_then_an_error_row(folder, capfd):
    """Case 1 sleeps forever: after 6 s its worker process is killed (a worker thread cannot be
    stopped) and the case handed out again; after 6 s more it is an error row; the others pass
    (each takes 0.04 s: the bound leaves room for a loaded machine's first case on a worker)."""
    path = write(folder, campaign(tags=3, mode="hang", misbehave_if_tag_mod3=1))
    code = main(["sweep", str(path), "--workers", "2", "--case-timeout", "6", "--out", str(folder / "out")])
    out, err = capfd.readouterr()
    assert code == 1 and "Traceback" not in err, err
    assert "3 cases, 2 passed, 1 failed" in out
    assert [(r["status"], r["error"]) for r in rows_of(folder)] == [
        ("ok", ""), ("error", "ran longer than the case timeout of 6 s, twice"), ("ok", "")]


@pytest.mark.parametrize("value", ["0", "-1", "nan", "inf", "1e400", "three"])
def test_a_case_timeout_that_is_not_a_positive_finite_number_is_refused(folder, capfd, value):
    assert main(["sweep", str(write(folder, campaign())), f"--case-timeout={value}", "--out", str(folder / "out")]) == 2
    err = error_lines(capfd.readouterr().err)
    assert err == [f"error: --case-timeout: must be a positive finite number of seconds, got '{value}'"]
    assert not (folder / "out").exists()


def test_the_default_case_timeout_follows_the_scenario():
    """60 s to start, 1 ms a physics step (testbed.campaign.case_timeout)."""
    from testbed.api import load
    from testbed.campaign.case_timeout import case_timeout_s

    assert case_timeout_s(load("reorient_campaign")) == pytest.approx(60 + 85 / 0.01 * 1e-3)


# --- workers that die -------------------------------------------------------------------------

# On 2 workers cases 2 and 5 kill theirs at once; before tasks were bound to their worker, case 4
# (moved onto a dying one) was blamed in 1 whole-suite run of 3.
@pytest.mark.slow
@pytest.mark.parametrize("workers", [1, 2])
def test_cases_that_end_their_worker_are_the_only_error_rows(folder, capfd, workers):
    """9 cases; tags 2, 5, 8 misbehave: a crash (os.abort), SIGTERM to their process, SIGINT to it.
    A worker ignores SIGINT (Ctrl-C is the command's), so case 8 runs to its end; the two others
    kill their worker twice and are error rows; no other case is blamed."""
    path = write(folder, campaign(tags=9, mode="mixed", misbehave_if_tag_mod3=2))
    code = main(["sweep", str(path), "--workers", str(workers), "--out", str(folder / "out")])
    out, err = capfd.readouterr()
    assert code == 1 and "Traceback" not in err, err
    errors = {int(r["case"]): r["error"] for r in rows_of(folder) if r["status"] != "ok"}
    assert errors == dict.fromkeys([2, 5], "the worker process died running it, 2 times"), errors
    assert "9 cases, 7 passed, 2 failed" in out


# --- a hand-started cluster, in another cwd ----------------------------------------------------

@pytest.fixture(scope="module")
def external_cluster(tmp_path_factory):
    """`dask scheduler` and one single-threaded `dask worker`, both started in a folder of their
    own (not the campaign's) with REFUSING_WORKER set; stopped after."""
    with hand_started_cluster(tmp_path_factory.mktemp("elsewhere"), REFUSING_WORKER="1") as address:
        yield address


@pytest.mark.slow
def test_a_case_that_kills_a_hand_started_worker_is_an_error_row(folder, capfd):
    """On a hand-started cluster (its scheduler retries a dead worker's task itself, 3 times by
    Dask's default) case 1 crashes its worker: it is run twice, then an error row; the two others
    pass, and the command ends on its own."""
    path = write(folder, campaign(tags=3, mode="crash", misbehave_if_tag_mod3=1))
    with hand_started_cluster(folder, ("w1", "w2")) as address:
        code = main(["sweep", str(path), "--scheduler", address, "--out", str(folder / "out")])
    out, err = capfd.readouterr()
    assert code == 1 and "Traceback" not in err, err
    assert [(r["status"], r["error"]) for r in rows_of(folder)] == [
        ("ok", ""), ("error", "the worker process died running it, 2 times"), ("ok", "")]


def test_a_plugin_named_relative_to_the_scenario_loads_in_a_worker_elsewhere(external_cluster, folder, capfd, monkeypatch):
    """The scenario names its plug-in "hostile_law.py" and is itself named relative to the cwd;
    the worker runs in another folder: every case runs (before: every row "no such plug-in file")."""
    data = campaign(tags=2, plugin="hostile_law.py")
    (PLUGIN["path"].parent / "relative.yaml").write_text(yaml.safe_dump(data))
    monkeypatch.chdir(PLUGIN["path"].parent)
    code = main(["sweep", "relative.yaml", "--scheduler", external_cluster, "--out", str(folder / "out")])
    out, err = capfd.readouterr()
    assert code == 0, err
    assert [(r["status"], r["error"]) for r in rows_of(folder)] == [("ok", ""), ("ok", "")]


def test_a_plugin_a_worker_cannot_load_is_refused_before_any_case_runs(external_cluster, folder, capfd):
    data = campaign(tags=2)
    data["plugins"].append(str(PLUGIN["path"].parent / "worker_refused.py"))
    code = main(["sweep", str(write(folder, data)), "--scheduler", external_cluster, "--out", str(folder / "out")])
    err = error_lines(capfd.readouterr().err)
    assert code == 2 and len(err) == 1, err
    assert err[0].startswith("error: plugins[1]: worker tcp://127.0.0.1:") and "cannot load it: " in err[0], err
    assert "worker_refused.py:4: RuntimeError: this worker refuses the plug-in" in err[0], err
    assert not (folder / "out").exists()


def test_a_case_that_runs_forever_on_an_external_cluster_is_an_error_row(external_cluster, folder, capfd):
    """Its worker thread cannot be stopped from here: the command stops waiting after 6 s, gives
    that thread nothing more and, the cluster's one thread held, ends with the rows it has.
    (Last of the tests on this cluster: its worker stays busy until the fixture stops it.)"""
    path = write(folder, campaign(tags=2, mode="hang", misbehave_if_tag_mod3=1))
    code = main(["sweep", str(path), "--scheduler", external_cluster, "--case-timeout", "6", "--out", str(folder / "out")])
    err = capfd.readouterr().err
    assert code == 1 and "Traceback" not in err, err
    assert [(r["status"], r["error"]) for r in rows_of(folder)] == [("ok", ""), (
        "error", "ran longer than the case timeout of 6 s, once; then not run: every worker thread is still "
                 "running a case that ran past its timeout")]
