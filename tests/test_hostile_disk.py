"""Output that cannot be written and input that cannot be read as numbers: a full disk (a small
tmpfs mounted in a private mount namespace), a stdout on /dev/full, integers of 5000 digits, the
trace a process left when it died mid-run."""

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

from campaign_cases import same_cells, spinup
from testbed.cli import main

ROOT = Path(__file__).resolve().parents[1]
SHORT = "sim.duration_s=0.5"
NO_SPACE = "No space left on device"
BIG = "1" * 5000


def _env() -> dict:
    return dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))


def _testbed(*argv, cwd: Path, timeout: float = 120, **popen) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "testbed", *map(str, argv)], cwd=cwd, env=_env(), text=True,
                          timeout=timeout, **({"capture_output": True} | popen))


@pytest.fixture
def cli(tmp_path, monkeypatch, capfd):
    monkeypatch.chdir(tmp_path)
    capfd.readouterr()

    def call(*argv):
        code = main([str(a) for a in argv])
        out, err = capfd.readouterr()
        return code, out, err
    return call


# --- a full disk: a tmpfs of a few kB, in a mount namespace of its own ---------------------

# Runs in `unshare -m`: mounts a tmpfs at DIR, runs each step (remounting the size it names),
# copies what is left in DIR to KEPT and prints one JSON list of the steps' outcomes.
DRIVER = textwrap.dedent('''\
    import json, shutil, subprocess, sys, time
    folder, kept, steps = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
    subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={steps[0]['size']}", "tmpfs", folder], check=True)
    done = []
    for step in steps:
        subprocess.run(["mount", "-o", f"remount,size={step['size']}", folder], check=True)
        t0 = time.monotonic()
        proc = subprocess.run(step["argv"], capture_output=True, text=True, timeout=step["timeout"])
        done.append({"code": proc.returncode, "out": proc.stdout, "err": proc.stderr, "s": time.monotonic() - t0})
    shutil.copytree(folder, kept)
    print(json.dumps(done))
''')


def _can_mount(tmp: Path) -> bool:
    target = tmp / "probe"
    target.mkdir()
    try:
        probe = subprocess.run(["unshare", "-m", "mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(target)],
                               capture_output=True, timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return probe.returncode == 0


@pytest.fixture(scope="module")
def full_disk(tmp_path_factory):
    """run(steps) -> (outcomes, files left): each step {"argv", "size", "timeout"} run with cwd
    the test folder against a tmpfs of `size` at <folder>/disk, the files left copied out."""
    if not _can_mount(tmp_path_factory.mktemp("mount")):
        pytest.skip("cannot mount a tmpfs in a private mount namespace here (needs unshare -m and mount)")

    def run(steps, name):
        folder = tmp_path_factory.mktemp(name)
        (folder / "disk").mkdir()
        kept = folder / "left"
        driver = subprocess.run(["unshare", "-m", sys.executable, "-c", DRIVER, str(folder / "disk"), str(kept),
                                 json.dumps(steps)], cwd=folder, env=_env(), capture_output=True, text=True,
                                timeout=sum(s["timeout"] for s in steps) + 60)
        assert driver.returncode == 0, driver.stderr[-3000:]
        files = sorted(str(p.relative_to(kept)) for p in kept.rglob("*") if p.is_file())
        return json.loads(driver.stdout), files, kept
    return run


def _testbed_argv(*argv) -> list[str]:
    return [sys.executable, "-m", "testbed", *map(str, argv)]


def test_a_run_on_a_full_disk_ends_in_one_line_and_leaves_no_trace(full_disk):
    """The whole torque_free_tumble trace is 2.6 MB; 100 kB fill while it runs (Rerun's file
    sink fails on its own thread): exit 1, one line naming the trace, nothing left on the disk."""
    (done,), files, _ = full_disk([{"argv": _testbed_argv("run", "torque_free_tumble", "--out", "disk/run.rrd"),
                                    "size": "100k", "timeout": 120}], "run")
    assert done["code"] == 1, done["err"][-3000:]
    lines = done["err"].splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and lines[0].endswith(f"run.rrd: {NO_SPACE}"), lines
    assert files == []  # no .rrd, no .partial, no probe


def test_a_run_on_a_disk_full_from_the_start_ends_in_one_line(full_disk):
    """No room even for the trace's header (Rerun writes it as the file sink opens)."""
    fill = [sys.executable, "-c", "open('disk/fill', 'wb').write(bytes(8192))"]
    (_, done), files, _ = full_disk([{"argv": fill, "size": "8k", "timeout": 30},
                                     {"argv": _testbed_argv("run", "torque_free_tumble", "--set", SHORT, "--out",
                                                            "disk/run.rrd"), "size": "8k", "timeout": 120}], "full")
    lines = done["err"].splitlines()
    assert done["code"] == 1 and len(lines) == 1 and lines[0].endswith(f"run.rrd: {NO_SPACE}"), done["err"][-3000:]
    assert files == ["fill"]


CAMPAIGN_CASES = 12


@pytest.fixture(scope="module")
def campaign(tmp_path_factory) -> Path:
    """A 12-case campaign of a 1 s spin-up, its initial rate and spin rate dispersed (about 500
    bytes a CSV row: the CSV outgrows a 4 kB page)."""
    folder = tmp_path_factory.mktemp("campaign")
    data = spinup("camp", {})
    data["sim"]["duration_s"] = 1
    data["sweep"] = {"seed": 3, "samples": CAMPAIGN_CASES,
                     "dispersions": {"pipeline.law.spin_rate_deg_s": {"uniform": [0.5, 1.5]},
                                     "initial.omega_deg_s": {"uniform": [-0.5, 0.5]}}}
    path = folder / "camp.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _uninterrupted_rows(campaign: Path) -> list[dict]:
    """Each case run alone in this process (bit for bit its row in a table, README "Seeds")."""
    from testbed.cli.campaign import load_cases
    from testbed.campaign.rows import run_case

    _, _, cases = load_cases(str(campaign), [])
    return [run_case(case) for case in cases]


def test_a_campaign_on_a_full_disk_keeps_its_rows_and_resumes_once_there_is_room(full_disk, campaign):
    """20 kB: room for campaign.json, the CSV and the Parquet file of no rows (16 kB of 4 kB
    pages), so the disk fills as the table grows: exit 1, one line naming the table's file, no
    temporary file left; with room again `--resume` runs the other cases, and the table holds
    each case's own row."""
    from testbed.campaign.table import read_parquet

    argv = _testbed_argv("sweep", campaign, "--workers", "1", "--out", "disk/out")
    (filled, resumed), files, kept = full_disk([{"argv": argv, "size": "20k", "timeout": 180},
                                                {"argv": [*argv, "--resume"], "size": "10m", "timeout": 180}],
                                               "camp")
    lines = filled["err"].splitlines()
    assert filled["code"] == 1 and len(lines) == 1, filled["err"][-3000:]
    assert lines[0].startswith("error: ") and f": {NO_SPACE}; " in lines[0] and "--resume" in lines[0], lines
    assert resumed["code"] in (0, 1) and "Traceback" not in resumed["err"], resumed["err"][-3000:]
    assert not [f for f in files if f.endswith(".partial")], files
    expected = _uninterrupted_rows(campaign)
    got = read_parquet(kept / "out" / "camp.parquet")
    assert len(got) == CAMPAIGN_CASES and all(same_cells(a, b) for a, b in zip(got, expected))
    assert resumed["code"] == (0 if all(row["passed"] for row in expected) else 1)


FILL_8K = [sys.executable, "-c", "open('disk/fill', 'wb').write(bytes(8192))"]


@pytest.mark.parametrize("size, failed", [("8k", "my_controller.py"), ("12k", "my_scenario.yaml")])
def test_init_on_a_full_disk_names_the_file_and_leaves_nothing(full_disk, size, failed):
    """#21 of the second round: init left an empty my_controller.py and exited 2. With no room
    (8k) the first template fails; with one 4 kB page free the controller (3985 bytes) fits and
    the scenario does not: exit 1, one line naming the file, neither template nor the folder
    init made is left (a later init starts afresh)."""
    (_, done), files, kept = full_disk([{"argv": FILL_8K, "size": size, "timeout": 30},
                                        {"argv": _testbed_argv("init", "disk/proj"), "size": size, "timeout": 60}],
                                       "init")
    lines = done["err"].splitlines()
    assert done["code"] == 1 and lines == [f"error: disk/proj/{failed}: {NO_SPACE}"], done["err"][-3000:]
    assert files == ["fill"] and not (kept / "proj").exists()


def test_a_case_rerun_on_a_full_disk_is_one_stderr_line(full_disk, campaign):
    """#22: `sweep --case N` printed its WriteFailed as an error row on stdout, then `trace:`
    naming a file that was not written. Now: exit 1, one stderr line naming the trace, no claim."""
    (_, done), files, _ = full_disk([{"argv": FILL_8K, "size": "12k", "timeout": 30},
                                     {"argv": _testbed_argv("sweep", campaign, "--case", "1", "--out", "disk/out"),
                                      "size": "12k", "timeout": 120}], "case")
    lines = done["err"].splitlines()
    assert done["code"] == 1 and len(lines) == 1, (done["out"][-2000:], done["err"][-3000:])
    assert lines[0].startswith("error: ") and lines[0].endswith(f"case0001.rrd: {NO_SPACE}"), lines
    assert "trace:" not in done["out"] and "WriteFailed" not in done["out"], done["out"]
    assert files == ["fill"]


def test_a_table_whose_disk_fills_names_its_file_and_keeps_its_rows(tmp_path, monkeypatch):
    """The same without a mount: ENOSPC injected at the CSV's write. The rows before stay whole,
    `--resume` reads them back, and no temporary file is left."""
    from testbed.campaign.table import CampaignTable
    from testbed.errors import WriteFailed

    columns = {"case": "int", "passed": "bool", "x": "float"}
    table = CampaignTable(tmp_path, "t", columns, {"fingerprint": "f", "cases": 2})
    table.open(resume=False)
    for case in (0, 1):
        table.append({"case": case, "passed": True, "x": 0.5 + case})

    class FullDisk:
        def __init__(self, handle):
            self.handle = handle

        def write(self, text):
            raise OSError(28, NO_SPACE)

        def flush(self):
            self.handle.flush()

        def close(self):
            self.handle.close()

    table._writer = csv.DictWriter(FullDisk(table._handle), fieldnames=list(columns))
    with pytest.raises(WriteFailed) as caught:
        table.append({"case": 2, "passed": True, "x": 2.5})
    assert str(caught.value) == f"{tmp_path / 't.csv'}: {NO_SPACE}"
    reopened = CampaignTable(tmp_path, "t", columns, {"fingerprint": "f", "cases": 2})
    assert sorted(reopened.open(resume=True)) == [0, 1]
    reopened.close()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["campaign.json", "t.csv", "t.parquet"]


def test_a_file_written_atomically_on_a_full_disk_is_named_and_leaves_nothing(tmp_path):
    from testbed.recording.atomic_file import atomic_file
    from testbed.errors import WriteFailed

    with pytest.raises(WriteFailed) as caught:
        with atomic_file(tmp_path / "summary.json"):
            raise OSError(28, NO_SPACE)  # as a write of its body would
    assert str(caught.value) == f"{tmp_path / 'summary.json'}: {NO_SPACE}"
    assert list(tmp_path.iterdir()) == []


# --- a stdout that cannot be written -------------------------------------------------------

@pytest.mark.parametrize("argv", [["run", "torque_free_tumble", "--set", SHORT, "--json", "--out", "r.rrd"],
                                  ["list"], ["inspect", "r.rrd"], ["inspect", "r.rrd", "--json"]], ids=" ".join)
def test_a_stdout_on_dev_full_costs_one_line_and_keeps_the_status(cli, argv, monkeypatch):
    """`testbed ... > /dev/full`: the command's own status (0: the run passed), one line on stderr."""
    if argv[0] == "inspect":
        assert cli("run", "torque_free_tumble", "--set", SHORT, "--out", "r.rrd")[0] == 0
    with open("/dev/full", "w") as full:
        monkeypatch.setattr(sys, "stdout", full)
        code, _, err = cli(*argv)
    assert err.splitlines() == [f"error: stdout: {NO_SPACE}"]
    assert code == 0


# --- integers of 5000 digits ---------------------------------------------------------------

def _file_with(tmp_path: Path, edit) -> Path:
    from testbed.scenario.shipped_files import SCENARIO_DIR

    text = (SCENARIO_DIR / "akor_sweep.yaml").read_text()
    path = tmp_path / "big.yaml"
    path.write_text(edit(text))
    return path


@pytest.mark.parametrize("case", ["set duration", "set sweep seed", "file seed", "list element"])
def test_an_integer_of_5000_digits_is_bad_input_naming_where(cli, tmp_path, case):
    if case == "set duration":
        code, out, err = cli("run", "torque_free_tumble", "--set", f"sim.duration_s=1{BIG}")
        where = "--set sim.duration_s"
    elif case == "set sweep seed":
        code, out, err = cli("sweep", "akor_sweep", "--set", f"sweep.seed={BIG}", "--out", tmp_path / "o")
        where = "--set sweep.seed"
    elif case == "file seed":
        path = _file_with(tmp_path, lambda text: text.replace("sweep:\n", f"sweep:\n  seed: {BIG}\n", 1))
        code, out, err = cli("sweep", path, "--out", tmp_path / "o")
        where = str(path)
    else:
        code, out, err = cli("run", "torque_free_tumble", "--set", f"initial.omega_deg_s=[1, {BIG}, 2]")
        where = "--set initial.omega_deg_s"
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith(f"error: {where}: "), err[:300]
    assert "an integer of more than 4300 digits" in err and len(err) < 300, err[:300]


# --- the trace of a process that died mid-run ----------------------------------------------

DYING_LAW = textwrap.dedent('''\
    import os, signal
    import numpy as np
    import testbed


    @testbed.stage("law", "test.dies")
    class Dies:
        outputs = ("torque",)

        def __init__(self, params, ctx):
            pass

        def torque(self, t, estimate):
            if t >= 0.3:
                os.abort()  # a crash (os._exit from a stage only fails the run: testbed/exit_guard.py)
            return {"torque": np.zeros(3)}


    @testbed.stage("law", "test.killed")
    class Killed(Dies):
        def torque(self, t, estimate):
            if t >= 0.3:
                os.kill(os.getpid(), signal.SIGKILL)
            return {"torque": np.zeros(3)}
    ''')


@pytest.mark.parametrize("how", ["abort", "sigkill"])
def test_inspect_reads_the_partial_trace_of_a_process_that_died(cli, tmp_path, how):
    """A plug-in law ends its process at t = 0.3 s (os.abort, or SIGKILL mid-run): the `.partial`
    left is read, said to be partial, exit 1; cut mid-message it is read to its last whole
    message (exit 1); a file of garbage is still refused (exit 2)."""
    (tmp_path / "dies.py").write_text(DYING_LAW)
    scenario = yaml.safe_load((ROOT / "scenarios" / "torque_free_tumble.yaml").read_text())
    scenario.update(name="dies", plugins=["dies.py"], checks={})
    scenario["pipeline"] = {"sensor": {"type": "ideal_attitude"}, "estimator": {"type": "attitude"},
                            "law": {"type": "test.dies" if how == "abort" else "test.killed"},
                            "allocator": {"type": "ideal_torque"}}
    scenario["sim"]["duration_s"] = 1.0
    (tmp_path / "dies.yaml").write_text(yaml.safe_dump(scenario))
    died = _testbed("run", "dies.yaml", "--out", "out/dies.rrd", cwd=tmp_path)
    assert died.returncode == (-6 if how == "abort" else -9), died.stderr[-3000:]
    (partial,) = (tmp_path / "out").glob(".dies.rrd.*.partial")

    shown = cli("inspect", partial, "--json")
    assert shown[0] == 1 and shown[2] == "", shown[2]
    info = json.loads(shown[1])
    assert info["finished"] is False and info["result"]["status"] == "error"
    assert "partial: the run did not finish" in cli("inspect", partial)[1]

    cut = tmp_path / "cut.rrd"
    cut.write_bytes(partial.read_bytes()[:-7])  # the last message cut short, as by a kill mid-write
    code, out, err = cli("inspect", cut, "--json")
    assert code == 1 and json.loads(out)["cut_bytes"] > 0, err

    garbage = tmp_path / "garbage.rrd"
    garbage.write_bytes(b"RRF2" + bytes(range(256)) * 16)
    code, out, err = cli("inspect", garbage)
    assert code == 2 and err.count("\n") == 1 and err.startswith("error: rrd: "), err


def test_a_trace_whose_end_rerun_could_not_write_is_no_finished_trace(cli, tmp_path, monkeypatch):
    """Rerun writes a file's end (its footer) on its own thread as the stream disconnects and says
    nothing when that write fails: a file whose end is cut short (here its last 40 bytes, inside
    the footer message, as a disk that filled mid-write leaves it; Rerun then refuses to read the
    file) is an error naming the file, exit 1, and no .rrd or .partial is left."""
    import rerun as rr

    written = []
    original = rr.RecordingStream.disconnect

    def cut_short(self):
        original(self)
        for partial in tmp_path.glob("*.partial"):
            os.truncate(partial, partial.stat().st_size - 40)
            written.append(partial)

    monkeypatch.setattr(rr.RecordingStream, "disconnect", cut_short)
    code, out, err = cli("run", "gyrostat_free", "--set", "sim.duration_s=2", "--out", str(tmp_path / "cut.rrd"))
    assert written and code == 1, err
    lines = err.splitlines()
    assert len(lines) == 1 and "cut.rrd" in lines[0] and "cut short" in lines[0], lines
    assert sorted(p.name for p in tmp_path.iterdir()) == []
