"""Sweeps (issue 5): expansion, the CSV table, parallel == serial, failing cases, bad input."""

import csv
import math

import numpy as np
import pytest
import yaml

from testbed.cli import main
from testbed.campaign.cases import expand
from testbed.campaign.rows import failure_cause, run_cases

# A short planar case: free decay only (6 s), so each case costs a fraction of a second.
BASE = {
    "name": "mini_sweep",
    "model": {"system": "planar", "inertia_kg_m2": 2.0, "initial_angle_rad": 0.1},
    "sim": {"duration_s": 6, "dt_s": 0.002, "control_period_s": 0.002, "trace_period_s": 0.02},
    "pipeline": {"sensor": {"type": "hinge_encoder"}, "estimator": {"type": "hinge_state"},
                 "law": {"type": "akor_lqr", "beta11": 4.0, "beta22": 1.0, "k": 1.0},
                 "allocator": {"type": "ideal_torque"}},
    "checks": {"akor_eta_rel_err": {"max": 0.01}},
    "sweep": {"seed": 3, "grid": {"pipeline.law.k": [1.0, 4.0]},
              "random": {"pipeline.law.beta22": {"uniform": [0.2, 1.0]}}, "samples": 2},
}


def _write(tmp_path, data, name="s.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return str(path)


def _rows(path):
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def test_cases_are_grid_times_seeded_draws(tmp_path):
    cases = expand(BASE)
    draws = np.random.default_rng(3).uniform(0.2, 1.0, size=4)
    assert [c.values for c in cases] == [
        {"pipeline.law.k": 1.0, "pipeline.law.beta22": draws[0]},
        {"pipeline.law.k": 1.0, "pipeline.law.beta22": draws[1]},
        {"pipeline.law.k": 4.0, "pipeline.law.beta22": draws[2]},
        {"pipeline.law.k": 4.0, "pipeline.law.beta22": draws[3]},
    ]
    assert cases[3].data["pipeline"]["law"] == {"type": "akor_lqr", "beta11": 4.0, "beta22": draws[3], "k": 4.0}
    assert "sweep" not in cases[0].data and BASE["pipeline"]["law"]["k"] == 1.0  # base untouched


@pytest.mark.slow
def test_sweep_csv_parallel_equals_serial_and_a_diverging_case_stays_in_its_row(tmp_path, capsys):
    data = dict(BASE, sweep={"grid": {"pipeline.law.k": [1.0, 4.0, 1.0e9]}})
    out = tmp_path / "out"
    assert main(["sweep", _write(tmp_path, data), "--workers", "2", "--out", str(out), "--rrd"]) == 1
    assert "3 cases, 2 passed, 1 failed" in capsys.readouterr().out
    rows = _rows(out / "mini_sweep.csv")
    assert [r["case"] for r in rows] == ["0", "1", "2"]
    assert list(rows[0])[:7] == ["case", "pipeline.law.k", "status", "passed", "error", "cause", "wall_s"]
    assert [r["cause"] == "" for r in rows] == [True, True, False] and rows[2]["cause"] == rows[2]["error"]
    for row, k in zip(rows[:2], (1.0, 4.0)):
        assert row["status"] == "ok" and row["passed"] == "True" and row["check:akor_eta_rel_err"] == "pass"
        # eq. 13 by hand: eta = sqrt(2 sqrt(k b11) + k b22) / 2 with b11 = 4, b22 = 1
        assert float(row["akor_eta_formula_1_s"]) == pytest.approx(math.sqrt(2 * math.sqrt(4 * k) + k) / 2, rel=1e-12)
        assert float(row["akor_eta_sim_1_s"]) == pytest.approx(float(row["akor_eta_formula_1_s"]), rel=0.01)
    # k = 1e9: the rate gain times Tc is ~60, the sampled loop blows up within a few ticks
    assert rows[2]["status"] == "diverged" and rows[2]["passed"] == "False"
    assert "diverged" in rows[2]["error"] and rows[2]["check:akor_eta_rel_err"] == "FAIL"
    assert sorted(p.name for p in out.glob("*.rrd")) == ["case0000.rrd", "case0001.rrd", "case0002.rrd"]
    # the same cases in this process, one after another: identical numbers
    serial = run_cases(expand(data), workers=1)
    for row, ref in zip(rows, serial):
        for key, value in ref.items():
            if key != "wall_s" and isinstance(value, float):
                assert float(row[key]) == value or (math.isnan(value) and row[key] == "nan"), key


def test_a_failed_case_names_its_cause():
    """`cause`: a run that stopped early gives its error; one that ran to the end the checks it
    failed, each with its value and limit; a passing one nothing (issue 37)."""
    checks = [{"name": "spin_error_final_deg_s", "value": 0.3137, "limit": "<= 0.02", "passed": False},
              {"name": "rate_limit_violations", "value": 0, "limit": "<= 0", "passed": True},
              {"name": "momentum_drift_rel", "value": None, "limit": "<= 1e-08", "passed": False}]
    assert failure_cause("ok", "", checks) == ("fails spin_error_final_deg_s = 0.314 (<= 0.02); "
                                               "momentum_drift_rel = None (<= 1e-08)")
    assert failure_cause("ok", "", checks[1:2]) == ""
    stopped = "stage estimator 'lebedev' left its validity at t = 159.35 s: the observer diverged: ..."
    assert failure_cause("method_failed", stopped, checks) == stopped


def test_a_case_that_raises_is_reported_not_fatal(tmp_path):
    """A stage pairing the schema accepts but the run refuses when it is prepared (estimator
    `attitude` behind the hinge encoder): that case errors in its row, the others run."""
    data = dict(BASE, sweep={"grid": {"pipeline.estimator.type": ["hinge_state", "attitude"]}})
    rows = run_cases(expand(data), workers=1)
    assert rows[0]["status"] == "ok" and rows[0]["passed"]
    assert rows[1]["status"] == "error" and "attitude needs a sensor" in rows[1]["error"]


@pytest.mark.parametrize("sweep, field", [
    ({}, "sweep"),
    ({"grid": {}}, "sweep"),
    ({"grid": {"pipeline.law.k": []}}, "sweep.grid.pipeline.law.k"),
    ({"grid": {"pipeline.law.kk": [1]}}, "sweep.grid.pipeline.law.kk"),
    ({"grid": {"model.bogus": [1]}}, "sweep.grid.model.bogus"),
    ({"grid": {"pipeline.law.k": [1, 0]}}, "sweep.grid.pipeline.law.k"),
    ({"grid": {"pipeline.law.beta11": [-1]}}, "sweep.grid.pipeline.law.beta11"),
    ({"grid": {"pipeline.law.beta22": [-0.5]}}, "sweep.grid.pipeline.law.beta22"),
    ({"random": {"pipeline.law.k": {"uniform": [1, 2]}}}, "sweep.samples"),
    ({"random": {"pipeline.law.k": {"gauss": [1, 2]}}, "samples": 2}, "sweep.random.pipeline.law.k.gauss"),
    (None, "sweep"),
])
def test_bad_sweeps_are_one_line_exit_2_and_nothing_is_written(sweep, field, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["sweep", _write(tmp_path, dict(BASE, sweep=sweep)), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: {field}:"), err
    assert not out.exists()


def test_bad_worker_count_exit_2(tmp_path, capsys):
    assert main(["sweep", _write(tmp_path, BASE), "--workers", "0", "--out", str(tmp_path / "o")]) == 2
    assert "--workers" in capsys.readouterr().err


def test_random_draws_follow_their_distributions_and_repeat_with_the_seed():
    from testbed.campaign.spec import assignments, load_spec

    block = {"random": {"a": {"choice": [1, "two", [3.0]]}, "b": {"integer": [2, 4]},
                        "c": {"uniform": [-1.0, 1.0]}, "d": {"log_uniform": [0.1, 10.0]}},
             "samples": 3000, "seed": 11}
    cases = assignments(load_spec(block))
    assert cases == assignments(load_spec(block))  # the seed fixes every draw
    a = [c["a"] for c in cases]
    # each choice about 1/3 of the time (binomial sigma ~ 26 draws)
    for value in (1, "two", [3.0]):
        assert abs(a.count(value) - 1000) < 130
    assert sorted({c["b"] for c in cases}) == [2, 3, 4]
    c = np.array([x["c"] for x in cases])
    assert c.min() >= -1.0 and c.max() <= 1.0 and abs(c.mean()) < 0.06  # sigma of the mean 0.011
    d = np.log10([x["d"] for x in cases])  # log-uniform: log10 uniform on [-1, 1]
    assert d.min() >= -1.0 and d.max() <= 1.0 and abs(d.mean()) < 0.06
