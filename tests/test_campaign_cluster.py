"""The campaign engine on Dask (issue 12): a real `dask scheduler` with two `dask worker`
processes gives the local cluster's numbers bit for bit, a worker that dies costs only its own
case, an unreachable scheduler is bad input."""

from __future__ import annotations

import copy
import csv
import json
import math
import os
import sys
from pathlib import Path

import pytest
import yaml

from campaign_cases import hand_started_cluster, spinup
from testbed.campaign.table import read_parquet
from testbed.cli import main

DASK = Path(sys.executable).with_name("dask")  # the CLI of the dask package, beside this Python

# The Lebedev one-gyro spin-up on a rigid bus, 20 s (tests/campaign_cases.py), 20 cases with
# every dispersion that has a random part.
CAMPAIGN = spinup("cluster_campaign", {"final_omega_rad_s": {"max": 0.01}}) | {
    "sweep": {"seed": 12, "samples": 10, "grid": {"sim.integrator": ["RK4", "Euler"]}, "dispersions": {
        "model.mass_kg": {"normal": [77000, 3000]},
        "model.inertia_kg_m2": {"truncated_normal": [0, 0.02, -0.03, 0.03], "relative": True},
        "initial.omega_deg_s": {"uniform": [-0.5, 0.5]},
        "pipeline.sensor.noise_sigma_rad_s": {"log_uniform": [1e-8, 1e-6]},
        "pipeline.sensor.bias_rad_s": {"normal": [0, 1e-6]},
        "pipeline.sensor.seed": {"integer": [0, 4294967295]},
        "pipeline.sensor.axis": {"misalignment_deg": 0.5}}}}


def write(folder: Path, data: dict, name: str = "campaign.yaml") -> str:
    path = folder / name
    path.write_text(yaml.safe_dump(data))
    return str(path)


def table(path: Path) -> list[dict]:
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def without_wall_time(rows: list[dict]) -> list[dict]:
    """The rows without their wall times, NaN as the text "nan" (so that NaN equals NaN)."""
    return [{k: "nan" if isinstance(v, float) and math.isnan(v) else v for k, v in row.items() if k != "wall_s"}
            for row in rows]


@pytest.fixture
def dask_cluster(tmp_path):
    """`dask scheduler` on a random localhost port and two single-threaded `dask worker`
    processes (each importing the testbed from this checkout), stopped after the test."""
    with hand_started_cluster(tmp_path, ("w1", "w2")) as address:
        yield address


@pytest.mark.slow
def test_a_dask_cluster_gives_the_local_clusters_table_and_each_case_alone(tmp_path, dask_cluster, capsys):
    """20 cases through --scheduler (a scheduler and two worker processes started here), the same
    through the local cluster, and each case rerun alone with --case N: the same rows, every
    metric bit for bit (the CSV holds floats as repr: exact), wall times aside."""
    path = write(tmp_path, CAMPAIGN)
    assert main(["sweep", path, "--scheduler", dask_cluster, "--out", str(tmp_path / "remote")]) in (0, 1)
    assert main(["sweep", path, "--workers", "2", "--out", str(tmp_path / "local")]) in (0, 1)
    capsys.readouterr()
    remote = table(tmp_path / "remote" / "cluster_campaign.csv")
    local = table(tmp_path / "local" / "cluster_campaign.csv")
    assert len(remote) == 20 and [r["case"] for r in remote] == [str(i) for i in range(20)]
    assert sum(r["status"] == "ok" for r in remote) == 20
    assert without_wall_time(remote) == without_wall_time(local)
    assert without_wall_time(read_parquet(tmp_path / "remote" / "cluster_campaign.parquet")) == without_wall_time(
        read_parquet(tmp_path / "local" / "cluster_campaign.parquet"))
    for i in range(20):
        assert main(["sweep", path, "--case", str(i), "--out", str(tmp_path / "alone"), "--json"]) in (0, 1)
        alone = json.loads(capsys.readouterr().out)
        for key, cell in remote[i].items():
            if key != "wall_s" and isinstance(alone.get(key), float):
                assert repr(alone[key]) == cell or (math.isnan(alone[key]) and cell == "nan"), (i, key)
            elif key != "wall_s":
                assert str(alone[key] if alone.get(key) is not None else "") == cell, (i, key)


@pytest.mark.slow
def test_an_unreachable_scheduler_is_bad_input(tmp_path, capsys):
    import socket

    with socket.socket() as probe:  # a port nothing listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    assert main(["sweep", write(tmp_path, CAMPAIGN), "--scheduler", address, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: --scheduler: ") and address in err[0]
    assert not (tmp_path / "out" / "cluster_campaign.csv").exists()


@pytest.mark.slow
def test_a_worker_that_dies_costs_only_its_own_case(tmp_path, capsys, logged_law):
    """Case 2's law kills its worker process: it is run twice (once more on another worker),
    then reported as an error; every other case runs once and passes."""
    log = tmp_path / "builds.log"
    data = {"name": "mortal", "plugins": [logged_law],
            "model": {"system": "satellite"}, "sim": {"duration_s": 2, "dt_s": 0.01},
            "pipeline": {"law": {"type": "test.logged", "die_at": 2, "log": str(log)},
                         "allocator": {"type": "ideal_torque"}},
            "checks": {"final_omega_rad_s": {"max": 1e-12}},
            "sweep": {"grid": {"pipeline.law.tag": [0, 1, 2, 3, 4, 5]}}}
    out = tmp_path / "out"
    assert main(["sweep", write(tmp_path, data), "--workers", "2", "--out", str(out)]) == 1
    assert "6 cases, 5 passed, 1 failed" in capsys.readouterr().out
    rows = table(out / "mortal.csv")
    assert [r["status"] for r in rows] == ["ok", "ok", "error", "ok", "ok", "ok"]
    assert "worker process died" in rows[2]["error"]
    runs = [line.split() for line in log.read_text().splitlines()]
    assert sorted(tag for tag, _ in runs) == ["0", "1", "2", "2", "3", "4", "5"]
    assert len({pid for tag, pid in runs if tag == "2"}) == 2  # on two different workers
    assert str(os.getpid()) not in {pid for _, pid in runs}


def test_workers_and_a_scheduler_together_are_refused(tmp_path, capsys):
    data = copy.deepcopy(CAMPAIGN)
    assert main(["sweep", write(tmp_path, data), "--workers", "2", "--scheduler", "tcp://127.0.0.1:1",
                 "--out", str(tmp_path / "o")]) == 2
    assert capsys.readouterr().err.startswith("error: --workers:")
