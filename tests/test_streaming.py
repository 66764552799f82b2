"""The trace as a stream: written chunk by chunk while the run goes, readable after a SIGKILL,
metrics from running reductions equal to the whole-history numpy expressions."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import yaml

from testbed.recording.recorder import CHUNK_ROWS, FLUSH_AFTER_S

ROOT = Path(__file__).resolve().parents[1]
KILL_AT_S = 30.0
STALL_AT_S = 25.0
STALL_S = 1.5 * FLUSH_AFTER_S  # [s] of wall time
TRACE_PERIOD_S = 0.01


def _testbed(*args, cwd: Path, timeout: float = 300) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "testbed", *map(str, args)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def killed_run(tmp_path_factory) -> tuple[Path, subprocess.CompletedProcess]:
    """A tumbling satellite whose law stalls STALL_S of wall time at t = STALL_AT_S and SIGKILLs
    its own process at t = KILL_AT_S (of 120 s): fewer than CHUNK_ROWS samples are recorded
    before the kill, so only the time-based flush (FLUSH_AFTER_S of wall time) writes them."""
    folder = tmp_path_factory.mktemp("killed")
    (folder / "kill_self.py").write_text(textwrap.dedent(f'''\
        import os, signal, time
        import numpy as np
        import testbed


        @testbed.stage("law", "test.kill_self")
        class KillSelf:
            outputs = ("torque",)

            def __init__(self, params, ctx):
                pass

            def torque(self, t, estimate):
                if abs(t - {STALL_AT_S}) < 1e-9:
                    time.sleep({STALL_S})
                if t >= {KILL_AT_S}:
                    os.kill(os.getpid(), signal.SIGKILL)
                return {{"torque": np.zeros(3)}}
        '''))
    scenario = {"name": "killed", "plugins": ["kill_self.py"],
                "model": {"system": "satellite", "inertia_kg_m2": [800, 1000, 1200]},
                "initial": {"omega_deg_s": [0.5, -0.3, 0.4]},
                "sim": {"duration_s": 120, "dt_s": 0.01, "control_period_s": 0.01, "trace_period_s": TRACE_PERIOD_S},
                "pipeline": {"sensor": {"type": "ideal_attitude"}, "estimator": {"type": "attitude"},
                             "law": {"type": "test.kill_self"}, "allocator": {"type": "ideal_torque"}}}
    (folder / "killed.yaml").write_text(yaml.safe_dump(scenario))
    done = _testbed("run", "killed.yaml", "--out", "out/killed.rrd", cwd=folder)
    return folder, done


def test_a_run_killed_with_sigkill_leaves_a_readable_partial_trace(killed_run):
    folder, done = killed_run
    assert done.returncode == -signal.SIGKILL, (done.returncode, done.stderr[-2000:])
    assert not (folder / "out" / "killed.rrd").exists()  # no finished trace: the rename never came
    partials = sorted((folder / "out").glob(".killed.rrd.*.partial"))
    assert len(partials) == 1, partials
    shown = _testbed("inspect", partials[0], "--json", cwd=folder)
    assert shown.returncode == 1, shown.stderr  # read, but no passed run: it did not finish
    info = json.loads(shown.stdout)
    assert info["finished"] is False
    # the samples up to the stall at least (the first sample after it is more than
    # FLUSH_AFTER_S of wall time after the last flush), none from the kill on, without a gap
    t_first, t_last = info["time_span_s"]
    assert t_first == 0.0 and STALL_AT_S <= t_last < KILL_AT_S, info["time_span_s"]
    rows = round(t_last / TRACE_PERIOD_S) + 1
    assert rows < CHUNK_ROWS  # no chunk filled up: the time-based flush wrote them
    for entity in ("/truth/omega", "/truth/quat", "/law/torque"):
        assert info["entities"].get(entity) == rows, (entity, info["entities"])  # its samples, as read gives them
    assert info["entities"].get("/world/bus", 0) >= rows
    result = info["result"]
    assert result["status"] == "error" and "did not finish" in result["error"]


@pytest.mark.filterwarnings("ignore:RRD file has no footer")  # a killed writer never wrote it
def test_the_partial_trace_holds_the_true_samples(killed_run):
    """The signals read back from the killed run equal a complete run of the same scenario
    stopped before the kill, sample for sample."""
    import testbed
    from testbed.recording.trace_reader import read_signals

    folder, _ = killed_run
    partial = next((folder / "out").glob(".killed.rrd.*.partial"))
    t, omega = read_signals(partial)["truth/omega"]
    spec = yaml.safe_load((folder / "killed.yaml").read_text())
    spec["plugins"] = [str(folder / "kill_self.py")]
    spec["sim"]["duration_s"] = KILL_AT_S - 1.0  # before the kill
    whole = testbed.run(spec)
    t_whole, omega_whole = whole.trace["truth/omega"]
    n = len(t)
    assert n > STALL_AT_S / TRACE_PERIOD_S and np.array_equal(omega, omega_whole[:n])
    assert np.allclose(t, t_whole[:n], atol=1e-9)


@pytest.fixture
def receiver(tmp_path):
    """A viewer-less Rerun gRPC receiver (`rerun --port P --save FILE`, no window): what a
    viewer would be sent lands in FILE as it arrives. Yields (url, FILE)."""
    import socket
    import time

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    received = tmp_path / "received.rrd"
    log = tmp_path / "receiver.log"
    with open(log, "w") as handle:
        # a session of its own: the `rerun` script starts the viewer binary as a child, which
        # must be stopped with it (the process group), not left listening
        proc = subprocess.Popen([str(Path(sys.executable).with_name("rerun")), "--port", str(port), "--save",
                                 str(received)], stdout=handle, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        deadline = time.monotonic() + 30
        while "Listening" not in log.read_text() and time.monotonic() < deadline:
            time.sleep(0.1)
        assert "Listening" in log.read_text(), log.read_text()
        yield f"rerun+http://127.0.0.1:{port}/proxy", received
    finally:
        os.killpg(proc.pid, signal.SIGTERM)
        proc.wait(timeout=30)


def _rows_received(path: Path, entity: str) -> int:
    """Rows of `entity` in a file another process is still writing (a torn last message is skipped)."""
    from rerun.chunk import RrdReader

    rows = 0
    try:
        for chunk in RrdReader(str(path)).stream():
            if str(chunk.entity_path) == entity:
                rows += chunk.to_record_batch().num_rows
    except Exception:  # noqa: BLE001  (the writer is mid-message)
        pass
    return rows


def test_a_live_sink_receives_the_run_in_chunks_before_it_ends(receiver, tmp_path):
    """`--connect URL` (and `--view`, which connects to the viewer it spawns): the receiver holds
    two whole chunks of samples while the run is still going (checked from inside the run, at
    its last progress report), and the whole trace once it ends; the .rrd is written too."""
    import time
    import warnings

    from testbed.cli import main
    from testbed.recording.live_view import ViewerStream
    from testbed.runner import run_scenario
    from testbed.scenario.loading import load_scenario

    url, received = receiver
    scenario = load_scenario("torque_free_tumble", ["sim.duration_s=120", "sim.control_period_s=0.01",
                                                    "sim.trace_period_s=0.01"])
    samples = round(120 / 0.01) + 1
    during = []

    def progress(fraction):
        if fraction >= 0.9 and not during:  # 10 800 samples recorded: two chunks flushed by now
            deadline = time.monotonic() + 30
            while _rows_received(received, "/truth/omega") < 2 * CHUNK_ROWS and time.monotonic() < deadline:
                time.sleep(0.2)
            during.append(_rows_received(received, "/truth/omega"))

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the receiver's file has no footer until it closes
        live = ViewerStream(url)
        result = run_scenario(scenario, tmp_path / "live.rrd", progress=progress, live=live)
        assert result.status == "ok" and (tmp_path / "live.rrd").exists() and live.complete
        assert during and 2 * CHUNK_ROWS <= during[0] - 1 < samples  # more than one chunk, not all of it
        deadline = time.monotonic() + 30
        while _rows_received(received, "/truth/omega") < samples + 1 and time.monotonic() < deadline:
            time.sleep(0.2)
        assert _rows_received(received, "/truth/omega") == samples + 1  # + the series' static row
        # the command line's flag reaches the same receiver
        assert main(["run", "torque_free_tumble", "--set", "sim.duration_s=10", "--out",
                     str(tmp_path / "cli.rrd"), "--connect", url]) == 0


def test_a_malformed_connect_url_is_bad_input(tmp_path, capsys):
    from testbed.cli import main

    assert main(["run", "torque_free_tumble", "--out", str(tmp_path / "x.rrd"), "--connect", "localhost:9876"]) == 2
    assert capsys.readouterr().err.startswith("error: --connect: ")
    assert list(tmp_path.iterdir()) == []


def test_running_reductions_equal_the_whole_history_expressions():
    """Fed in chunks of random sizes, each reduction gives exactly the numpy expression over the
    whole history (NaN rows included where np.max propagates them)."""
    from testbed.recording.recorder import Chunk
    from testbed.recording.reductions import First, Last, MaxAbs, MaxDistanceFromFirst, MaxNorm, Reductions

    rng = np.random.default_rng(15)
    values = rng.normal(size=(1000, 3)) * np.exp(rng.normal(size=(1000, 1)) * 5)
    time = np.arange(1000) * 0.1
    reductions = [MaxNorm("v"), MaxAbs("v"), MaxDistanceFromFirst("v"), First("v"), Last("v")]
    running = Reductions(reductions)
    cuts = np.sort(rng.choice(np.arange(1, 1000), size=7, replace=False))
    for lo, hi in zip([0, *cuts], [*cuts, 1000]):
        running.update(Chunk(int(lo), time[lo:hi], {"v": values[lo:hi]}))
    assert running.value(MaxNorm("v")) == np.max(np.linalg.norm(values, axis=1))
    assert running.value(MaxAbs("v")) == np.max(np.abs(values))
    assert running.value(MaxDistanceFromFirst("v")) == np.max(np.linalg.norm(values - values[0], axis=1))
    assert np.array_equal(running.value(First("v")), values[0])
    assert np.array_equal(running.value(Last("v")), values[-1])
    with_nan = Reductions([MaxNorm("v")])
    with_nan.update(Chunk(0, time[:2], {"v": np.array([[1.0, 0, 0], [np.nan, 0, 0]])}))
    with_nan.update(Chunk(2, time[2:3], {"v": np.array([[5.0, 0, 0]])}))
    assert np.isnan(with_nan.value(MaxNorm("v")))


def test_the_windowed_reduced_cmg_reference_agrees_with_the_whole_run_integration():
    """The reduced CMG model integrated in windows of 200 samples (state carried over, splines
    fitted with 64 samples of margin) against the same model integrated over the whole run at
    once: they differ by the integrator's own error at rtol 1e-9 (the whole-run solutions at
    rtol 1e-9 and 1e-11 differ by 4.8e-9 rad/s here; windowed vs whole 3.6e-9, the same with
    a margin of 16 samples), far below the 1e-6 rad/s the shipped check allows; and one window
    that holds the whole run is the whole-run integration, bit for bit."""
    import testbed
    from testbed.recording.reference_windows import WindowedReference
    from testbed.systems.cmg_cluster.reduced_model import CmgMassModel, reduced_cmg_omega, reduced_cmg_segment

    result = testbed.run("cmg_open_loop", overrides=["sim.duration_s=120", "reference=", "checks={}"])
    keys = ("truth/gimbal_angle", "truth/gimbal_rate", "truth/rotor_rate", "truth/omega")
    recorder = result.data.recorder
    times, histories = recorder.time, {key: recorder[key] for key in keys}
    plant, _, _ = testbed.runner.prepare(testbed.load("cmg_open_loop"))
    mass_model, omega0 = CmgMassModel.from_model(plant.model), plant.omega()
    whole = reduced_cmg_omega(mass_model, times, *(histories[k] for k in keys[:3]), omega0, times, rtol=1e-9)

    def segment(t, h, lo, hi, momentum):
        return reduced_cmg_segment(mass_model, t, *(h[k] for k in keys[:3]), t[lo:hi + 1],
                                   omega0=omega0 if momentum is None else None, momentum0=momentum, rtol=1e-9)

    for window, tolerance in ((200, 1e-8), (len(times), 0.0)):
        windowed = WindowedReference(segment, keys[:3], None, window=window)
        parts = []
        for lo in range(0, len(times), 97):  # chunks that do not line up with the windows
            chunk = testbed.recording.recorder.Chunk(lo, times[lo:lo + 97], {k: v[lo:lo + 97] for k, v in histories.items()})
            parts.append(windowed.update(chunk))
        parts.append(windowed.finish())
        parts = [p for p in parts if p is not None]
        assert [p.first_row for p in parts] == sorted(p.first_row for p in parts)
        omega = np.concatenate([p.signals["reference/omega"] for p in parts])
        assert omega.shape == whole.shape
        assert np.max(np.abs(omega - whole)) <= tolerance, (window, np.max(np.abs(omega - whole)))


def test_an_enveloped_trace_holds_every_full_rate_sample_between_its_min_and_max(tmp_path):
    """sim.trace_envelope_s: the .rrd holds per block the min and max of every signal; each
    sample of the same run at full rate lies within its block's envelope, the bounds are
    attained (they are the block's extremes, not padded), and the file has fewer rows."""
    import testbed
    from testbed.recording.trace_reader import read_signals

    rng = np.random.default_rng(15)
    inertia = sorted(rng.uniform(200, 2000, 3))  # a body not in the repository, tumbling about a random axis
    axis = rng.normal(size=3)
    spec = {"name": "enveloped", "model": {"system": "satellite", "inertia_kg_m2": [float(i) for i in inertia]},
            "initial": {"omega_deg_s": [float(w) for w in 2.0 * axis / np.linalg.norm(axis)]},
            "sim": {"duration_s": 47.3, "dt_s": 0.01, "control_period_s": 0.01, "trace_period_s": 0.01,
                    "trace_envelope_s": 0.7},
            "pipeline": {"sensor": {"type": "ideal_attitude"}, "estimator": {"type": "attitude"},
                         "law": {"type": "lebedev", "task": "detumble", "residual_rate_deg_s": 0.1, "gains_per_s": [-0.1, -0.1, -0.1]}, "allocator": {"type": "ideal_torque"}}}
    result = testbed.run(spec, out=tmp_path / "enveloped.rrd")
    assert result.status == "ok"
    written = read_signals(tmp_path / "enveloped.rrd")
    rows = 70  # 0.7 s of 0.01 s samples
    for key in ("truth/omega", "truth/quat", "law/torque"):
        t, full = result.trace[key]
        t_env, low = written[f"{key}/min"]
        _, high = written[f"{key}/max"]
        assert len(t_env) < 2 * len(t) / rows + 20  # two rows a block (+ blocks cut by chunk ends)
        starts, ends = t_env[0::2], t_env[1::2]
        block = np.searchsorted(starts, t + 1e-9, side="right") - 1  # the block each sample falls in
        assert np.all(t <= ends[block] + 1e-9)  # the blocks cover every sample
        lo, hi = low[0::2][block], high[0::2][block]
        assert np.all(lo <= full) and np.all(full <= hi), key
        for k in range(len(starts)):  # each bound is a sample's value
            inside = full[block == k]
            assert np.array_equal(lo[block == k][0], inside.min(axis=0)) and np.array_equal(hi[block == k][0], inside.max(axis=0))
    assert "truth/omega" not in written  # the full-rate series is not written


def test_an_envelope_must_be_whole_trace_periods():
    import testbed
    from testbed.errors import InputError

    spec = {"name": "bad", "model": {"system": "satellite", "inertia_kg_m2": [800, 1000, 1200]},
            "sim": {"duration_s": 10, "dt_s": 0.01, "trace_period_s": 0.1, "trace_envelope_s": 0.25},
            "pipeline": {"sensor": {"type": "ideal_attitude"}, "estimator": {"type": "attitude"}, "law": {"type": "lebedev", "task": "detumble", "residual_rate_deg_s": 0.1, "gains_per_s": [-0.1, -0.1, -0.1]}, "allocator": {"type": "ideal_torque"}}}
    with pytest.raises(InputError, match="trace_envelope_s"):
        testbed.run(spec)


def _fed_in_chunks(reductions_, time, signals, rng, cuts=9):
    """A Reductions fed `signals` (key -> (n, ...)) in chunks cut at random rows."""
    from testbed.recording.recorder import Chunk
    from testbed.recording.reductions import Reductions

    running = Reductions(reductions_)
    edges = np.sort(rng.choice(np.arange(1, len(time)), size=cuts, replace=False))
    for lo, hi in zip([0, *edges], [*edges, len(time)]):
        running.update(Chunk(int(lo), time[lo:hi], {key: v[lo:hi] for key, v in signals.items()}))
    return running


def _column(chunk):
    return chunk.signals.get("v")


def test_row_reductions_and_windows_equal_the_whole_history_expressions():
    """Mean, NaN-aware maxima, the value at a time and the peak ratio of consecutive windows,
    fed in random chunks, against the numpy expression over the whole history (NaN rows where
    the signal was not recorded, as the trace's last row holds only the truth)."""
    from testbed.recording.reductions import FirstFrom, Mean, NanMax, NanMaxBefore, WindowPeakRatio

    rng = np.random.default_rng(151)
    n = 2000
    time = np.arange(n) * 0.05
    values = rng.normal(size=(n, 3)) * np.exp(rng.normal(size=(n, 1)))
    values[rng.choice(n, 40, replace=False)] = np.nan
    values[-1] = np.nan
    reds = [NanMax("v"), Mean(_column), NanMaxBefore(_column, 31.4), FirstFrom(_column, 31.4),
            WindowPeakRatio("v", 5.0)]
    running = _fed_in_chunks(reds, time, {"v": values}, rng)
    assert running.value(NanMax("v")) == np.nanmax(values)
    finite = values[~np.isnan(values[:, 0])]
    assert np.isnan(running.value(Mean(_column))).all()  # a NaN row makes the mean NaN, as np.mean
    assert np.array_equal(running.value(NanMaxBefore(_column, 31.4)), np.nanmax(values[time < 31.4], axis=0))
    assert np.array_equal(running.value(FirstFrom(_column, 31.4)), values[np.flatnonzero(time >= 31.4)[0]],
                          equal_nan=True)
    means = _fed_in_chunks([Mean(_column)], time[: len(finite)], {"v": finite}, rng).value(Mean(_column))
    np.testing.assert_allclose(means, np.mean(finite, axis=0), rtol=1e-14, atol=0)
    # peak |v| of each 5 s window (NaN rows make their window's peak NaN, as np.max)
    clean = np.where(np.isnan(values), 1.0, values)
    norms = np.linalg.norm(clean, axis=1) * np.exp(-time / 20)
    peaks = np.array([np.max(norms[(time >= 5 * k - 1e-9) & (time < 5 * (k + 1) - 1e-9)]) for k in range(20)])
    ratio = _fed_in_chunks([WindowPeakRatio("v", 5.0)], time, {"v": clean * np.exp(-time / 20)[:, None]}, rng)
    assert ratio.value(WindowPeakRatio("v", 5.0)) == np.max(peaks[1:] / peaks[:-1])
    assert np.isnan(running.value(WindowPeakRatio("v", 5.0)))


@pytest.mark.parametrize("ends_at", [99.95, 71.3, 7.0])
def test_a_tail_window_equals_the_whole_history_one_when_the_run_ends_early_or_on_time(ends_at, monkeypatch):
    """TailMean and TailNanMax over t >= t_e - f (t_e - t_0), planned t_e = 99.95 s: a run that
    ends on time (the aggregate kept over the planned window), and runs cut short at 71.3 s and
    7 s (the samples kept for that case); with fewer samples kept than the early window holds,
    the value is refused, not wrong."""
    from testbed.recording import reductions
    from testbed.recording.reductions import TailMean, TailNanMax

    rng = np.random.default_rng(152)
    time = np.arange(2000) * 0.05
    values = rng.normal(size=(2000, 2)) + 3.0
    values[rng.choice(2000, 30, replace=False), 1] = np.nan
    n = np.searchsorted(time, ends_at) + 1
    time, values = time[:n], values[:n]
    mean, peak = TailMean(_column, 0.2, 99.95), TailNanMax(_column, 0.1, 99.95)
    running = _fed_in_chunks([mean, peak], time, {"v": values}, rng)
    tail = time >= time[-1] - 0.2 * (time[-1] - time[0])
    np.testing.assert_allclose(running.value(mean), np.mean(values[tail], axis=0), rtol=1e-14, atol=0)
    assert not np.isnan(running.value(mean)[0]) and np.isnan(running.value(mean)[1])
    last = time >= time[-1] - 0.1 * (time[-1] - time[0])
    assert np.array_equal(running.value(peak), np.nanmax(values[last], axis=0))
    monkeypatch.setattr(reductions, "CUT_SHORT_ROWS", int(tail.sum()) - 1)
    few = _fed_in_chunks([mean], time, {"v": values}, rng)
    if ends_at == 99.95:
        np.testing.assert_allclose(few.value(mean), running.value(mean), rtol=1e-15, atol=0)
    else:
        with pytest.raises(ValueError, match="before its planned end"):
            few.value(mean)


def test_a_long_run_is_written_without_the_footer_and_reads_back_whole(tmp_path, monkeypatch):
    """Rerun's footer (a manifest of every chunk, kept in memory until the file ends: the memory
    of a long run grew with it) ends a short run's file and not a long one's; both read back
    with every sample."""
    from testbed import read, run
    from testbed.recording import trace
    from testbed.scenario.loading import load_scenario

    scenario = load_scenario("cmg_open_loop", ["sim.duration_s=10", "reference=", "checks={}"])  # 101 samples
    footer_magic = b"RRF2FOOT"
    for limit, has_footer in ((trace.FOOTER_MAX_SAMPLES, True), (50, False)):
        monkeypatch.setattr(trace, "FOOTER_MAX_SAMPLES", limit)
        out = tmp_path / f"limit{limit}.rrd"
        run(scenario, out)
        assert out.read_bytes()[-64:].find(footer_magic) >= 0 if has_footer else footer_magic not in out.read_bytes()[-64:]
        t, omega = read(out).trace["truth/omega"]
        assert len(t) == 101 and t[-1] == pytest.approx(10.0)
