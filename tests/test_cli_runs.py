"""The CLI end to end: run, --json, inspect reads back the stored result, failures, divergence."""

import json
import sys

import numpy as np
import pytest

from testbed.cli import main
from testbed.scenario.shipped_files import SCENARIO_DIR
from testbed.recording.trace_reader import read_rrd

SHORT_GYROSTAT = ["run", "gyrostat_free", "--set", "sim.duration_s=20", "--json"]


def test_run_json_and_inspect_agree(tmp_path, capsys):
    out = tmp_path / "g.rrd"
    assert main(SHORT_GYROSTAT + ["--out", str(out)]) == 0
    result = json.loads(capsys.readouterr().out)
    assert set(result) >= {"scenario", "sim_s", "wall_s", "metrics", "checks", "rrd"}
    assert result["sim_s"] == pytest.approx(20.0)
    assert all(c["passed"] for c in result["checks"])
    assert main(["inspect", str(out), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["result"]["metrics"] == result["metrics"]
    assert info["result"]["checks"] == result["checks"]
    assert info["time_span_s"] == pytest.approx([0.0, 20.0])
    assert {"/truth/omega", "/truth/angular_momentum_world", "/reference/omega_error", "/world/bus"} <= set(info["entities"])
    # one sample per trace period plus the final state
    assert info["entities"]["/truth/omega"] >= 201


def test_recorded_signal_matches_the_summary_metric(tmp_path, capsys):
    """The max omega error in the file's columns equals the metric stored beside it."""
    from rerun.chunk import RrdReader

    out = tmp_path / "g.rrd"
    main(SHORT_GYROSTAT + ["--out", str(out)])
    metric = json.loads(capsys.readouterr().out)["metrics"]["max_omega_error_rad_s"]
    rows = []
    for chunk in RrdReader(str(out)).stream():
        batch = chunk.to_record_batch()
        if str(chunk.entity_path) == "/reference/omega_error" and "Scalars:scalars" in batch.schema.names:
            rows += [r for r in batch.column("Scalars:scalars").to_pylist() if r is not None]
    assert np.max(np.linalg.norm(np.array(rows), axis=1)) == pytest.approx(metric, rel=1e-12)


def test_failing_check_exits_1(tmp_path, capsys):
    argv = SHORT_GYROSTAT + ["--out", str(tmp_path / "g.rrd"), "--set", "checks.momentum_drift_rel={max: 1e-30}"]
    assert main(argv) == 1
    result = json.loads(capsys.readouterr().out)
    assert [c["passed"] for c in result["checks"] if c["name"] == "momentum_drift_rel"] == [False]


@pytest.mark.parametrize("torque, inertia, warning", [
    (1.0e9, 1.0e-3, "BADQACC"),   # qacc = 1e12 exceeds MuJoCo's limit: it would reset the state
    (1.0e12, 1.0, "BADCTRL"),     # a huge command: MuJoCo would zero it silently
])
def test_divergence_stops_with_a_clear_error_and_a_readable_trace(torque, inertia, warning, tmp_path,
                                                                    capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)  # MuJoCo writes its MUJOCO_LOG.TXT into the working directory
    out = tmp_path / "d.rrd"
    argv = ["run", "torque_free_skylab", "--out", str(out), "--json",
            "--set", f"model.inertia_kg_m2=[{inertia}, {inertia}, {inertia}]", "--set", "reference=",
            "--set", "checks={}",
            "--set", f"pipeline={{law: {{type: torque_profile, offset: [0, 0, {torque}], start_s: 10}}, "
                     "allocator: {type: ideal_torque}}"]
    assert main(argv) == 1
    result = json.loads(capsys.readouterr().out)
    assert result["status"] == "diverged" and "diverged at t = 10" in result["error"]
    assert warning in result["error"]
    info = read_rrd(out)
    assert info["result"]["status"] == "diverged"
    assert 9.0 <= info["time_span_s"][1] <= 10.5


def test_divergence_inside_a_block_of_unchecked_ticks_names_the_window_that_holds_it(tmp_path, monkeypatch):
    """The plant is checked for a bad state once per block of ticks (runner.CHECK_EVERY_TICKS):
    a torque too large for MuJoCo switched on at 13 s, inside the block that starts at 10 s
    (ticks of 0.5 s, a trace sample every 10 ticks), is reported in a window that contains
    13 s, and the trace stops at the last sample before it."""
    from testbed.runner import run_scenario
    from testbed.scenario.loading import load_scenario

    monkeypatch.chdir(tmp_path)  # MuJoCo writes its MUJOCO_LOG.TXT into the working directory
    scenario = load_scenario("torque_free_skylab", [
        "model.inertia_kg_m2=[0.001, 0.001, 0.001]", "reference=", "checks={}", "sim.trace_period_s=5",
        "pipeline={law: {type: torque_profile, offset: [0, 0, 1.0e9], start_s: 13}, allocator: {type: ideal_torque}}"])
    result = run_scenario(scenario, None, keep_data=True)
    assert result.status == "diverged" and "BADQACC" in result.error
    start = float(result.error.split("diverged at t = ")[1].split(" s")[0])
    steps = int(result.error.split("within ")[1].split(" steps")[0])
    assert start <= 13.0 < start + steps * scenario.sim.dt_s
    assert start + steps * scenario.sim.dt_s - 13.0 <= 5.0 + 1e-9  # the window is one block long at most
    assert result.trace["truth/omega"][0][-1] <= 13.0


def test_list_names_every_scenario(capsys):
    assert main(["list"]) == 0
    listed = {line.split()[0] for line in capsys.readouterr().out.splitlines()}
    assert listed == {p.stem for p in SCENARIO_DIR.glob("*.yaml")}


def test_check_prints_a_table_and_fails_on_a_failed_check(tmp_path, capsys):
    scenario = tmp_path / "tight.yaml"
    scenario.write_text((SCENARIO_DIR / "gyrostat_free.yaml").read_text()
                        .replace("duration_s: 300", "duration_s: 5").replace("max: 1.0e-10", "max: 1.0e-30"))
    assert main(["check", str(scenario), "--out-dir", str(tmp_path)]) == 1
    table = capsys.readouterr().out
    assert "momentum_drift_rel" in table and "FAIL" in table and "pass" in table


def test_each_command_builds_each_plant_and_reads_each_file_once(tmp_path, capsys, monkeypatch):
    """The straight data walk (docs/architecture.md): `check` of two scenarios builds two plants,
    not four; `run` checks its output path once; `inspect` reads the file in one pass."""
    import testbed.cli.inspect_trace, testbed.cli.run, testbed.runner  # noqa: F401  (before the patching below)
    from testbed.recording import output_paths, trace_reader
    from testbed.systems import registry

    counts = {"plants": 0, "paths": 0, "passes": 0}

    def counting(name, function):
        def counted(*args, **kwargs):
            counts[name] += 1
            return function(*args, **kwargs)
        return counted

    monkeypatch.setattr(registry, "make_plant", counting("plants", registry.make_plant))
    original = output_paths.output_path
    check_path = counting("paths", original)
    for module in [m for m in list(sys.modules.values()) if m and m.__name__.startswith("testbed")]:
        if getattr(module, "output_path", None) is original:  # wherever it was imported
            monkeypatch.setattr(module, "output_path", check_path)
    monkeypatch.setattr(trace_reader, "_chunks", counting("passes", trace_reader._chunks))
    short = ["--set", "sim.duration_s=2"]
    out = tmp_path / "g.rrd"
    assert main(["run", "gyrostat_free", *short, "--out", str(out)]) == 0
    assert (counts["plants"], counts["paths"]) == (1, 1)
    assert main(["inspect", str(out)]) == 0
    assert counts["passes"] == 1
    counts.update(plants=0)
    assert main(["check", "gyrostat_free", "torque_free_tumble", "--out-dir", str(tmp_path)]) in (0, 1)
    assert counts["plants"] == 2
    capsys.readouterr()


@pytest.mark.parametrize("value, limit, passed, shown", [
    (1.0000000000000002, "<= 1", False, "1.0000000000000002"),   # printed as 1 beside FAIL before
    (0.9999999999999999, ">= 1", False, "0.9999999999999999"),
    (1.00004, "<= 1", False, "1.00004"),                 # 4 figures read 1 (passing): 6 needed
    (1.00004, "<= 2", True, "1"),                                  # a pass keeps 4 figures
    (0.2, ">= 0.1 and <= 0.3", True, "0.2"),
    (float("nan"), "<= 1", False, "nan"),
])
def test_a_value_is_never_printed_passing_beside_fail(value, limit, passed, shown):
    from testbed.metrics import value_text

    assert value_text(value, limit, passed) == shown


def test_a_limit_is_printed_exactly():
    from testbed.scenario.loading import CheckLimit

    assert CheckLimit(max=1.0).text == "<= 1"
    assert CheckLimit(max=1.0000001, min=-2.5).text == "<= 1.0000001 and >= -2.5"  # :g read 1
def test_inspect_counts_the_samples_read_gives(tmp_path, capsys):
    """`testbed inspect` and `testbed.read` count a signal's rows alike: its samples on sim_time
    that hold a value (the flagship's law has none at t = 0, before its first control step; the
    static series style is no sample). 2 s at 0.05 s: 41 samples of the truth."""
    import testbed

    out = tmp_path / "f.rrd"
    assert main(["run", "lebedev_spinup_cmg", "--set", "sim.duration_s=2", "--out", str(out), "--json"]) in (0, 1)
    capsys.readouterr()
    assert main(["inspect", str(out), "--json"]) == 0
    entities = json.loads(capsys.readouterr().out)["entities"]
    trace = testbed.read(out).trace
    signals = [e for e in entities if e.lstrip("/") in trace]
    assert len(signals) > 20 and entities["/truth/omega"] == 41
    assert {e: entities[e] for e in signals} == {e: len(trace[e.lstrip("/")][0]) for e in signals}


def test_explain_gives_each_metric_its_registered_meaning(tmp_path, capsys):
    """`--explain`: the first line of each metric's registration beside its value, in the text
    summary and as `meanings` in --json."""
    from testbed.metrics import METRICS

    out = tmp_path / "g.rrd"
    assert main(["run", "gyrostat_free", "--set", "sim.duration_s=1", "--out", str(out), "--explain"]) == 0
    text = capsys.readouterr().out
    assert main(SHORT_GYROSTAT + ["--out", str(out), "--explain"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["meanings"] == {name: METRICS[name].doc for name in result["metrics"]}
    assert result["notes"] == {}
    for name in result["metrics"]:
        line = next(l for l in text.splitlines() if l.split()[:1] == [name])
        assert line.endswith(METRICS[name].doc)


def test_building_notice_shows_after_its_delay_and_completes_with_the_time():
    """The line appears only once building has taken `after_s`, and ends with its duration."""
    import io
    import time

    from testbed.cli.progress import building_notice

    quick, slow, hidden = io.StringIO(), io.StringIO(), io.StringIO()
    with building_notice("x", True, after_s=0.5, stream=quick):
        pass
    with building_notice("big", True, after_s=0.05, stream=slow):
        time.sleep(0.3)
    with building_notice("big", False, after_s=0.0, stream=hidden):
        time.sleep(0.1)
    assert quick.getvalue() == "" and hidden.getvalue() == ""
    line = slow.getvalue()
    assert line.startswith("building big (model, pipeline, reference) ...") and line.endswith(" s\n")
    assert float(line.split("...")[1].split()[0]) >= 0.3 - 0.05


def test_a_run_that_builds_slowly_says_so_on_a_terminal(tmp_path, monkeypatch, capsys):
    """`testbed run` on a terminal: building (here made to take 1.3 s) shows the line after
    BUILD_NOTICE_S = 1 s; the run then goes on as ever."""
    import time

    import testbed.run_core.plan
    from testbed.cli import progress

    real = testbed.run_core.plan.prepare

    def slow(*args, **kwargs):
        time.sleep(progress.BUILD_NOTICE_S + 0.3)
        return real(*args, **kwargs)

    monkeypatch.setattr(testbed.run_core.plan, "prepare", slow)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True, raising=False)
    assert main(["run", "gyrostat_free", "--set", "sim.duration_s=0.5", "--out", str(tmp_path / "g.rrd")]) == 0
    err = capsys.readouterr().err
    assert "building gyrostat_free (model, pipeline, reference) ..." in err
