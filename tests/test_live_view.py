"""`--view` and `--connect` open or refuse, never hang (testbed.recording.live_view): each case ends
within 60 s, SIGTERM ends a streamed run at once, and nothing half-written is left."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from testbed.recording.live_view import PROBE_S, grpc_silence

RUN = ["run", "torque_free_tumble", "--set", "sim.duration_s=5"]
BOUND_S = 60.0  # the bound on every case here


def run_cli(argv, cwd: Path, env=None, timeout: float = BOUND_S):
    """`python -m testbed argv` in `cwd`: (exit status, stderr)."""
    proc = subprocess.run([sys.executable, "-m", "testbed", *argv], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout, env=env)
    return proc.returncode, proc.stderr


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.fixture
def silent_server():
    """A port that accepts connections and never answers (the case that hung until SIGKILL)."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    held, stop = [], threading.Event()

    def accept():
        server.settimeout(0.2)
        while not stop.is_set():
            try:
                held.append(server.accept()[0])
            except OSError:
                continue

    thread = threading.Thread(target=accept, daemon=True)
    thread.start()
    yield f"rerun+http://127.0.0.1:{server.getsockname()[1]}/proxy"
    stop.set()
    thread.join(5)
    for conn in held:
        conn.close()
    server.close()


@pytest.fixture
def grpc_server():
    """A real Rerun gRPC server without a window (`rerun --serve-grpc`); yields (url, stop)."""
    port = free_port()
    proc = subprocess.Popen([str(Path(sys.executable).with_name("rerun")), "--serve-grpc", "--port", str(port)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)

    def stop():
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(timeout=30)

    deadline = time.monotonic() + 30
    while grpc_silence("127.0.0.1", port, 1.0) is not None and time.monotonic() < deadline:
        time.sleep(0.2)
    try:
        yield f"rerun+http://127.0.0.1:{port}/proxy", stop
    finally:
        stop()


def no_display_env() -> dict:
    return {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}


def test_view_with_no_display_is_refused_before_the_run(tmp_path):
    """It printed "Rerun is disabled - spawn() call ignored", ran, and never exited."""
    code, err = run_cli([*RUN, "--out", "x.rrd", "--view"], tmp_path, env=no_display_env())
    assert code == 2 and err.startswith("error: --view: no display") and len(err.splitlines()) == 1, err
    assert list(tmp_path.iterdir()) == []


def test_view_whose_viewer_cannot_start_is_refused(tmp_path, monkeypatch, capsys):
    """A display but no viewer executable: refused, one line, before anything is written."""
    import testbed.recording.live_view as live_view
    from testbed.cli import main

    monkeypatch.setenv("DISPLAY", ":0")
    monkeypatch.setattr(live_view, "viewer_executable", lambda: None)
    monkeypatch.setattr(live_view, "VIEWER_PORT", free_port())
    monkeypatch.chdir(tmp_path)
    assert main([*RUN, "--out", "x.rrd", "--view"]) == 2
    assert capsys.readouterr().err.startswith("error: --view: no Rerun viewer executable")
    assert list(tmp_path.iterdir()) == []


def test_connect_where_nothing_listens_is_refused(tmp_path):
    code, err = run_cli([*RUN, "--out", "x.rrd", "--connect", f"rerun+http://127.0.0.1:{free_port()}/proxy"],
                                     tmp_path)
    assert code == 2 and "error: --connect: no Rerun viewer answers at" in err and "refused" in err, err
    assert list(tmp_path.iterdir()) == []


def test_connect_to_a_port_that_never_answers_is_refused(tmp_path, silent_server):
    """It accepted the connection and hung the run at its end, SIGTERM ignored."""
    code, err = run_cli([*RUN, "--out", "x.rrd", "--connect", silent_server], tmp_path)
    assert code == 2 and f"no answer within {PROBE_S:g} s" in err, err
    assert list(tmp_path.iterdir()) == []


def streamed_run(cwd: Path, url: str, overrides: list[str]) -> subprocess.Popen:
    """`testbed run torque_free_tumble` streamed to `url`, returned once its trace file exists
    and half a second has gone by (the run is under way)."""
    argv = [sys.executable, "-m", "testbed", "run", "torque_free_tumble", "--out", "x.rrd", "--connect", url]
    for override in overrides:
        argv += ["--set", override]
    proc = subprocess.Popen(argv, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + BOUND_S
    while not list(cwd.glob(".x.rrd.*.partial")) and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.05)
    time.sleep(0.5)
    return proc


def test_a_viewer_that_goes_away_mid_run_costs_a_note_not_the_run(tmp_path, grpc_server):
    """The viewer killed 0.5 s into the run: the run ends on its own with its own status, the
    trace file whole and readable, and one note on stderr instead of an error a flush."""
    import testbed

    url, stop = grpc_server
    proc = streamed_run(tmp_path, url, ["sim.duration_s=600", "sim.trace_period_s=0.01", "sim.control_period_s=0.01"])
    try:
        stop()
        _, err = proc.communicate(timeout=BOUND_S)
    finally:
        proc.kill()
    assert proc.returncode == 0, err
    notes = [line for line in err.splitlines() if line]
    assert len(notes) == 1 and notes[0].startswith(f"note: the viewer at {url} did not take the whole run"), err
    assert testbed.read(tmp_path / "x.rrd").sim_s == pytest.approx(600.0)
    assert not list(tmp_path.glob("*.partial"))


@pytest.mark.parametrize("signum, code", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_a_signal_ends_a_streamed_run_at_once(tmp_path, grpc_server, signum, code):
    url, _ = grpc_server
    proc = streamed_run(tmp_path, url, ["sim.duration_s=3000"])
    try:
        proc.send_signal(signum)
        _, err = proc.communicate(timeout=BOUND_S)
    finally:
        proc.kill()
    assert proc.returncode == code, err
    assert list(tmp_path.iterdir()) == []
