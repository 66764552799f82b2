"""A campaign's table survives (issue 12): rows appended as cases finish, Ctrl-C keeps every
finished row and stops the rest, --resume runs only the cases the table lacks."""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

from testbed.campaign.table import CampaignTable, merge_kinds, read_parquet
from testbed.cli import main
from testbed.errors import InputError

CASES = 16


def campaign(folder: Path, plugin: str, seed: int = 1) -> str:
    """16 cases of a tumbling rigid bus, about 0.5 s each (5 s at a 1 ms step), each tagged."""
    data = {"name": "survivor", "plugins": [plugin],
            "model": {"system": "satellite", "inertia_kg_m2": [800, 1000, 1200]},
            "initial": {"omega_deg_s": [1, 2, 3]},
            "sim": {"duration_s": 5, "dt_s": 0.001, "control_period_s": 0.001, "trace_period_s": 0.1},
            "pipeline": {"law": {"type": "test.logged", "log": str(folder / "runs.log")},
                         "allocator": {"type": "ideal_torque"}},
            "checks": {"final_omega_rad_s": {"max": 1.0}},
            "sweep": {"seed": seed, "samples": 1, "grid": {"pipeline.law.tag": list(range(CASES))},
                      "dispersions": {"model.mass_kg": {"normal": [1000, 10]}}}}
    path = folder / "survivor.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


def group_ends(group: int, within_s: float = 10.0) -> bool:
    """Whether every process of the group is gone (a dead child waits for init to reap it)."""
    deadline = time.monotonic() + within_s
    while time.monotonic() < deadline:
        try:
            os.killpg(group, 0)
        except ProcessLookupError:
            return True
        time.sleep(0.1)
    return False


def csv_rows(path: Path) -> list[dict]:
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


@pytest.mark.slow
def test_ctrl_c_keeps_every_finished_row_and_resume_runs_each_other_case_once(tmp_path, capsys, logged_law):
    path, out = campaign(tmp_path, logged_law), tmp_path / "out"
    table = out / "survivor.csv"
    # Ctrl-C on a terminal reaches the whole process group: the command and its worker processes
    command = subprocess.Popen([sys.executable, "-m", "testbed", "sweep", path, "--workers", "2", "--out", str(out)],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while not table.exists() or len(table.read_text().splitlines()) < 1 + 3:
            assert time.monotonic() < deadline and command.poll() is None, command.communicate()
            time.sleep(0.05)
        os.killpg(command.pid, signal.SIGINT)
        sent = time.monotonic()
        stdout, stderr = command.communicate(timeout=60)
        stopped_after = time.monotonic() - sent
    finally:
        if command.poll() is None:
            os.killpg(command.pid, signal.SIGKILL)
    print(f"Ctrl-C to exit: {stopped_after:.2f} s")
    assert command.returncode == 130 and "Traceback" not in stderr, stderr
    assert "stopped:" in stderr and "--resume runs the other" in stderr
    assert group_ends(command.pid)  # no worker process outlives the command
    kept = csv_rows(table)
    assert 3 <= len(kept) < CASES and all(r["passed"] == "True" for r in kept)
    assert [int(r["case"]) for r in kept] == sorted(int(r["case"]) for r in kept)
    assert [r["case"] for r in read_parquet(out / "survivor.parquet")] == [int(r["case"]) for r in kept]
    ran_before = [line.split()[0] for line in (tmp_path / "runs.log").read_text().splitlines()]

    assert main(["sweep", path, "--workers", "2", "--out", str(out), "--resume"]) == 0
    assert f"{CASES} cases, {CASES} passed" in capsys.readouterr().out
    final = csv_rows(table)
    assert [int(r["case"]) for r in final] == list(range(CASES))
    assert [final[int(r["case"])] for r in kept] == kept  # the kept rows, wall times and all
    runs = [line.split()[0] for line in (tmp_path / "runs.log").read_text().splitlines()]
    for case in range(CASES):
        tag = str(case)  # the grid gives case i the tag i
        if any(int(r["case"]) == case for r in kept):
            assert runs.count(tag) == 1  # finished before Ctrl-C: not run again
        else:  # run on resume; once more if it was running when Ctrl-C came
            assert runs.count(tag) == 1 + ran_before.count(tag)
    parquet = read_parquet(out / "survivor.parquet")
    assert [r["case"] for r in parquet] == list(range(CASES))
    assert all(repr(p["model.mass_kg"]) == c["model.mass_kg"] for p, c in zip(parquet, final))


def test_resume_refuses_another_campaigns_table(tmp_path, capsys):
    out = tmp_path / "out"
    columns = {"case": "int", "passed": "bool", "x": "float"}
    CampaignTable(out, "survivor", columns, {"fingerprint": "another"}).open(resume=False)
    with pytest.raises(InputError) as err:
        CampaignTable(out, "survivor", columns, {"fingerprint": "this"}).open(resume=True)
    assert err.value.field == "--resume" and "another campaign" in err.value.reason


def test_a_row_cut_short_by_a_crash_is_dropped_and_its_case_runs_again(tmp_path):
    """A killed command can leave half a CSV line: --resume keeps the whole rows only, typed as
    before (ints, floats exact, bools, text), and the Parquet file holds the same."""
    out = tmp_path / "out"
    rows = [{"case": 0, "passed": True, "x": 0.1 + 0.2, "label": "a,b"}, {"case": 2, "passed": False, "x": None,
                                                                          "label": ""}]
    columns: dict = {}
    for row in rows:
        merge_kinds(columns, row)
    assert columns == {"case": "int", "passed": "bool", "x": "float", "label": "str"}
    table = CampaignTable(out, "t", columns, {"fingerprint": "f", "cases": 3})
    table.open(resume=False)
    for row in rows:
        table.append(row)
    with open(out / "t.csv", "a") as handle:  # what a kill -9 in the middle of a write leaves
        handle.write("1,Tr")
    again = CampaignTable(out, "t", columns, {"fingerprint": "f", "cases": 3})
    assert again.open(resume=True) == {0: rows[0], 2: rows[1]}
    assert again.close() == rows
    assert read_parquet(out / "t.parquet") == rows
    assert csv_rows(out / "t.csv")[0]["x"] == repr(0.1 + 0.2)


def test_kinds_widen_ints_to_floats_and_mixed_cells_to_text():
    columns: dict = {}
    merge_kinds(columns, {"a": 1, "b": True, "c": None, "d": 1})
    merge_kinds(columns, {"a": 2.5, "b": "x", "c": 3, "d": True})
    assert columns == {"a": "float", "b": "str", "c": "int", "d": "str"}
