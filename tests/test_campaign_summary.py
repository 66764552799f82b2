"""A campaign's statistics and pictures (issue 12): the pass rate's interval against the beta
quantiles and the closed form, the spreads against numpy, the worst cases and their rerun
commands, summary.json and the histograms and scatter plots of summary.rrd against the table."""

from __future__ import annotations

import csv
import json
import math
import shlex

import numpy as np
import pytest
import rerun as rr
import yaml
from scipy import stats

from campaign_cases import spinup
from testbed.campaign.plots import TIMELINE, axis_scale
from testbed.campaign.stats import by_grid_point, check_margin, metric_spread, pass_rate, report, summary, worst_cases
from testbed.cli import main

# The Lebedev one-gyro spin-up on a rigid bus, 20 s (the observer alone: the bus tumbles freely
# at about |w(0)| = 0.00617 rad/s): 12 cases, the initial rate dispersed so that some fail the
# (deliberately tight) check on the final rate.
CAMPAIGN = spinup("summary_campaign", {"final_omega_rad_s": {"max": 0.0062}}, noise_rad_s=None) | {
    "sweep": {"seed": 3, "samples": 6, "grid": {"sim.integrator": ["RK4", "Euler"]}, "dispersions": {
        "initial.omega_deg_s": {"uniform": [-0.05, 0.05], "offset": True},
        "pipeline.sensor.axis": {"misalignment_deg": 1.0}}}}


def test_checked_metrics_by_grid_point_are_the_means_of_its_cases():
    """Two grid fields, two samples a point: each point's mean of each checked metric over its
    finite values (a NaN and a missing value skipped, a point with none gives None), in case order;
    the terminal lists the points, an unchecked metric left out."""
    rows = [{"case": i, "k": k, "c": c, "passed": True, "status": "ok", "error": "", "t_s": t, "x": 1.0}
            for i, (k, c, t) in enumerate([(1, 5, 2.0), (1, 5, 4.0), (2, 5, float("nan")), (2, 5, 7.0),
                                           (1, 9, None), (1, 9, float("nan"))])]
    points = by_grid_point(rows, ["k", "c"], ["t_s"])
    assert [(p["values"], p["cases"], p["means"]["t_s"]) for p in points] == [
        ({"k": "1", "c": "5"}, 2, 3.0), ({"k": "2", "c": "5"}, 2, 7.0), ({"k": "1", "c": "9"}, 2, None)]
    limits = {row["case"]: {"t_s": {"max": 10.0}} for row in rows}
    lines = report(summary("g", rows, ["t_s", "x"], limits, lambda case: f"rerun {case}", [], ["k", "c"]))
    table = lines[lines.index("checked metrics by grid point (mean over its cases):") + 1:][:4]
    assert [line.split() for line in table] == [["k", "c", "t_s"], ["1", "5", "3"], ["2", "5", "7"], ["1", "9", "-"]]


def test_pass_rate_interval_is_clopper_pearson():
    """Against the beta quantiles (Clopper & Pearson's own form) and, for all passed, the closed
    form ((1 - c) / 2)^(1/n)."""
    for passed, cases in [(0, 10), (7, 10), (130, 200), (200, 200)]:
        rate = pass_rate(passed, cases)
        low = stats.beta.ppf(0.025, passed, cases - passed + 1) if passed else 0.0
        high = stats.beta.ppf(0.975, passed + 1, cases - passed) if passed < cases else 1.0
        assert rate["rate"] == passed / cases
        assert rate["low"] == pytest.approx(low, abs=1e-9) and rate["high"] == pytest.approx(high, abs=1e-9)
    assert pass_rate(200, 200)["low"] == pytest.approx(0.025 ** (1 / 200), rel=1e-9)  # 0.98172


def test_metric_spread_and_check_margins():
    values = [1.0, 2.0, None, float("nan"), 4.0, 10.0, float("inf")]
    spread = metric_spread(values)
    x = np.array([1.0, 2.0, 4.0, 10.0])
    assert spread["cases"] == 4 and spread["not_finite"] == 2
    assert spread["mean"] == 4.25 and spread["sigma"] == pytest.approx(math.sqrt(((x - 4.25) ** 2).sum() / 3))
    assert spread["p50"] == 3.0 and spread["max"] == 10.0
    assert spread["p5"] == pytest.approx(1.0 + 0.15 * 1.0) and spread["p95"] == pytest.approx(4.0 + 0.85 * 6.0)
    assert check_margin(0.5, {"max": 2.0}) == 0.75 and check_margin(3.0, {"max": 2.0}) == -0.5
    assert check_margin(1.0, {"min": 0.0}) == 1.0 and check_margin(1.0, {"min": 2.0, "max": 3.0}) == -0.5
    assert check_margin(float("nan"), {"max": 1.0}) == -math.inf


def test_worst_cases_put_errors_first_then_failures_then_the_smallest_margin():
    rows = [{"case": 0, "status": "ok", "passed": True, "error": "", "m": 0.5},
            {"case": 1, "status": "ok", "passed": False, "error": "", "m": 1.5},
            {"case": 2, "status": "diverged", "passed": False, "error": "diverged at t = 3 s", "m": None},
            {"case": 3, "status": "ok", "passed": True, "error": "", "m": 0.9},
            {"case": 4, "status": "ok", "passed": False, "error": "", "m": 1.1},
            {"case": 5, "status": "ok", "passed": True, "error": "", "m": 0.1}]
    for row in rows:
        row["count"] = 0  # at its limit in every case: it tells no case apart
    limits = {i: {"m": {"max": 1.0, "min": None}, "count": {"max": 0, "min": None}} for i in range(6)}
    worst = worst_cases(rows, limits, lambda case: f"rerun {case}")
    assert [w["case"] for w in worst] == [2, 1, 4, 3, 0]
    assert worst[0]["why"] == "diverged at t = 3 s" and worst[1]["rerun"] == "rerun 1"
    assert worst[1]["why"] == "m = 1.5 (fails <= 1)" and worst[1]["margin"] == -0.5


def read_summary_rrd(path):
    """histogram entity -> (counts, centres); scatter entity -> (x, y) from the .rrd file."""
    from rerun.chunk import RrdReader

    bars, points = {}, {}
    for chunk in RrdReader(str(path)).stream():
        entity, batch = str(chunk.entity_path), chunk.to_record_batch()
        if "BarChart:values" in batch.schema.names:
            bars[entity] = (np.array(batch.column("BarChart:values").to_pylist()[0][0]["buffer"]),
                            np.array(batch.column("BarChart:abscissa").to_pylist()[0][0]["buffer"]))
        if TIMELINE in batch.schema.names:
            x = batch.column(TIMELINE).cast("int64").to_numpy()
            y = batch.column("Scalars:scalars").flatten().to_numpy()
            old = points.get(entity, (np.empty(0), np.empty(0)))
            points[entity] = (np.concatenate([old[0], x]), np.concatenate([old[1], y]))
    return bars, points


@pytest.mark.slow
def test_summary_json_rrd_and_terminal_agree_with_the_table(tmp_path, capsys):
    path, out = tmp_path / "c.yaml", tmp_path / "out"
    path.write_text(yaml.safe_dump(CAMPAIGN))
    assert main(["sweep", str(path), "--workers", "2", "--out", str(out)]) == 1
    printed = capsys.readouterr().out
    with open(out / "summary_campaign.csv", newline="") as handle:
        rows = list(csv.DictReader(handle))
    summary = json.loads((out / "summary" / "summary.json").read_text())
    passed = sum(r["passed"] == "True" for r in rows)
    assert 0 < passed < 12  # the tight check splits the cases
    assert summary["pass_rate"]["passed"] == passed and summary["cases"] == 12
    low = stats.beta.ppf(0.025, passed, 12 - passed + 1)
    assert summary["pass_rate"]["low"] == pytest.approx(low, abs=1e-9)
    assert f"pass rate {passed}/12" in printed
    assert all(r["status"] == "ok" for r in rows) and "status: ok 12\n" in printed  # every case ran to its end
    final = np.array([float(r["final_omega_rad_s"]) for r in rows])
    assert summary["metrics"]["final_omega_rad_s"]["p50"] == np.median(final)
    assert summary["metrics"]["final_omega_rad_s"]["max"] == final.max()
    # the worst five: the failed cases with the largest final rate first, each with its rerun command
    failed = sorted((r for r in rows if r["passed"] == "False"), key=lambda r: -float(r["final_omega_rad_s"]))
    assert [w["case"] for w in summary["worst"][:len(failed)]] == [int(r["case"]) for r in failed][:5]
    rerun = summary["worst"][0]["rerun"]
    assert rerun in printed and shlex.split(rerun)[:2] == ["testbed", "sweep"]
    assert main([*shlex.split(rerun)[1:], "--json"]) == 1
    again = json.loads(capsys.readouterr().out)
    assert repr(again["final_omega_rad_s"]) == rows[summary["worst"][0]["case"]]["final_omega_rad_s"]

    bars, points = read_summary_rrd(out / "summary" / "summary.rrd")
    counts, centres = bars["/histogram/final_omega_rad_s"]
    edges_counts, edges = np.histogram(final, bins=len(counts))
    assert counts.sum() == 12 and np.array_equal(counts, edges_counts) and np.allclose(centres, (edges[1:] + edges[:-1]) / 2)
    assert summary["parameters"][:4] == ["sim.integrator", "initial.omega_deg_s[0]", "initial.omega_deg_s[1]",
                                         "initial.omega_deg_s[2]"]
    assert "pipeline.sensor.axis:misalignment_deg" in summary["parameters"]
    # each scatter plot: x = the parameter / 10^(k - 3) to four digits, y = the metric, passed and
    # failed cases apart
    for parameter in ("initial.omega_deg_s[1]", "pipeline.sensor.axis:misalignment_deg"):
        values = np.array([float(r[parameter]) for r in rows])
        scale = 10.0 ** (axis_scale(values) - 3)
        for outcome in ("passed", "failed"):
            chosen = [i for i, r in enumerate(rows) if (r["passed"] == "True") == (outcome == "passed")]
            x, y = points[f"/scatter/final_omega_rad_s/{rr.escape_entity_path_part(parameter)}/{outcome}"]
            assert sorted(zip(x, y)) == sorted(zip(np.round(values[chosen] / scale), final[chosen]))
    # a text parameter is plotted by the index of its value: RK4 0, Euler 1
    x, _ = points["/scatter/final_omega_rad_s/sim.integrator/failed"]
    assert set(x) <= {0.0, 1.0}
