"""Where `testbed run` and `testbed check` put a trace without --out: runs/<scenario file stem>.rrd,
never over the trace of another scenario file (docs/cli.md "Where a trace goes")."""

import json
import pytest

from testbed.cli import main
from testbed.scenario.shipped_files import SCENARIO_DIR
from testbed.recording.trace_reader import read_rrd

SHORT = ["--set", "sim.duration_s=0.5", "--json"]


@pytest.fixture
def cwd(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return tmp_path


def scenario_copy(folder, stem, **changes):
    """gyrostat_free.yaml copied to folder/<stem>.yaml (its `name:` kept), lines replaced by `changes`."""
    folder.mkdir(parents=True, exist_ok=True)
    text = (SCENARIO_DIR / "gyrostat_free.yaml").read_text()
    for old, new in changes.items():
        assert old in text
        text = text.replace(old, new)
    path = folder / f"{stem}.yaml"
    path.write_text(text)
    return path


def test_a_broken_copy_with_the_same_name_keeps_the_original_trace(cwd, capsys):
    """The issue's case: bad.yaml, a copy with the same `name:` whose run fails, writes
    runs/bad.rrd; runs/good.rrd still holds the good run."""
    good = scenario_copy(cwd, "good")
    bad = scenario_copy(cwd, "bad")
    assert main(["run", str(good), *SHORT]) == 0
    assert json.loads(capsys.readouterr().out)["rrd"] == str(cwd / "runs" / "good.rrd")
    kept = (cwd / "runs" / "good.rrd").read_bytes()
    assert main(["run", str(bad), *SHORT, "--set", "checks.momentum_drift_rel={max: 1e-30}"]) == 1
    assert json.loads(capsys.readouterr().out)["rrd"] == str(cwd / "runs" / "bad.rrd")
    assert (cwd / "runs" / "good.rrd").read_bytes() == kept
    assert read_rrd(cwd / "runs" / "good.rrd")["result"]["status"] == "ok"


def test_a_name_writes_the_trace_of_that_file(cwd, capsys):
    assert main(["run", "gyrostat_free", *SHORT]) == 0
    assert json.loads(capsys.readouterr().out)["rrd"] == str(cwd / "runs" / "gyrostat_free.rrd")


def test_another_file_of_the_same_stem_is_refused_and_the_trace_kept(cwd, capfd):
    first = scenario_copy(cwd / "a", "spin")
    second = scenario_copy(cwd / "b", "spin")
    assert main(["run", str(first), *SHORT]) == 0
    kept = (cwd / "runs" / "spin.rrd").read_bytes()
    capfd.readouterr()
    assert main(["run", str(second), *SHORT]) == 2
    err = capfd.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "another scenario file" in err and "a/spin.yaml" in err
    assert (cwd / "runs" / "spin.rrd").read_bytes() == kept
    # testbed check refuses the same way, before anything runs
    assert main(["check", str(second), "--json"]) == 2
    assert (cwd / "runs" / "spin.rrd").read_bytes() == kept
    # --out keeps its meaning: the trace goes where it says, whatever is there
    assert main(["run", str(second), *SHORT, "--out", "runs/spin.rrd"]) == 0
    assert (cwd / "runs" / "spin.rrd").read_bytes() != kept


def test_the_same_file_run_again_replaces_its_trace(cwd, capsys):
    """A rerun of one file replaces its trace whatever its outcome: the trace of the failed run
    is the one to look at."""
    path = scenario_copy(cwd, "mine")
    assert main(["run", str(path), *SHORT]) == 0
    assert main(["run", str(path), *SHORT, "--set", "checks.momentum_drift_rel={max: 1e-30}"]) == 1
    stored = read_rrd(cwd / "runs" / "mine.rrd")["result"]
    assert [c["passed"] for c in stored["checks"] if c["name"] == "momentum_drift_rel"] == [False]


def test_a_relative_and_an_absolute_path_name_one_file(cwd, capsys):
    """The source is compared as a resolved path: a relative and an absolute spelling are one file."""
    path = scenario_copy(cwd, "rel")
    assert main(["run", "rel.yaml", *SHORT]) == 0
    assert main(["run", str(path), *SHORT]) == 0
