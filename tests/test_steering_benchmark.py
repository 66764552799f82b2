"""The steering benchmark (bench/steering_benchmark.py) on a small sample: its envelope radii are the
hand-derived ones, its cases are reproducible by seed, and every law flies the same cases to the
analytic end momentum H_w(T) = 0 when it keeps exact torque."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "bench" / "steering_benchmark.py"


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("steering_benchmark", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_envelope_radius_is_the_hand_derived_one(bench):
    # Along z every unit can turn its h onto +z (beta_i = 90 deg along s_i z): 4 h. Along x, unit i's
    # h sweeps the circle normal to g_i = s_i (e_i x z), whose largest x-component is
    # |x x g_i| = sqrt(1 - sin^2 alpha) = cos alpha: 4 h cos alpha.
    geo = bench.geometry()
    assert bench.envelope_radius(geo, [0, 0, 1]) == pytest.approx(4.0, rel=1e-4)
    assert bench.envelope_radius(geo, [1, 0, 0]) == pytest.approx(4 * np.cos(np.radians(bench.ALPHA_DEG)), rel=1e-4)


def test_cases_are_reproducible_and_within_the_stated_range(bench):
    cases = bench.cases(6, seed=3, sweep=1)
    assert cases == bench.cases(6, seed=3, sweep=1) and cases[:5] == bench.cases(5, seed=3)
    assert len(cases) == 6 + 1 * len(bench.START_SETS_DEG) * len(bench.FRACTIONS)
    for case in cases[:6]:
        assert bench.LOWEST_H / case["radius"] <= case["fraction"] <= bench.HIGHEST_FRACTION
    peak = bench.wanted_momentum(cases[0], bench.DURATION_S / 2)
    assert np.linalg.norm(peak) == pytest.approx(cases[0]["fraction"] * cases[0]["radius"], rel=1e-12)


def test_every_law_flies_the_small_sample(bench, tmp_path):
    # Three slews, every law. A case counted exact has kept the torque within 1e-3 of the demand, so
    # it ends at the path's analytic end H_w(T) = 0 up to the last step's second-order term
    # (|beta'|^2 dt^2 / 2 <= 1e-3 h at 30 deg/s, dt = 0.05 s).
    geo, cases = bench.geometry(), bench.cases(3, seed=bench.SEED)
    rows = [bench.fly(law, case, geo) for case in cases for law in bench.LAWS]
    assert any(r["exact"] for r in rows)
    for row in rows:
        assert row["peak_gimbal_rate_deg_s"] <= bench.RATE_MAX_DEG_S * (1 + 1e-9)
        if row["exact"]:
            assert row["final_momentum_error_h"] < 1e-3
    text = bench.table(rows, bench.LAWS)
    for law in bench.LAWS:
        assert f"{law:<14}usable up to f = " in text
    shares = bench.exact_shares(rows, "pinv")
    assert np.count_nonzero(~np.isnan(shares)) == len({bench.bin_of(c["fraction"]) for c in cases})  # the bins it filled
    assert bench.write_plot(tmp_path / "plot.rrd", rows, bench.LAWS).stat().st_size > 0


def test_null_vector_is_normal_to_the_columns_with_the_cauchy_binet_length():
    from testbed.steering.planned_path import null_vector
    rng = np.random.default_rng(0)
    for _ in range(5):
        J = rng.normal(size=(3, 4))
        n = null_vector(J)
        assert np.abs(J @ n).max() < 1e-12 * np.abs(J).max() ** 3
        assert np.linalg.norm(n) == pytest.approx(np.sqrt(np.linalg.det(J @ J.T)), rel=1e-10)


def test_reconfiguration_follows_the_rhombus_zero_momentum_line(bench):
    # By hand: through (45, -45, -45, 45) deg the rhombus's zero-momentum fibre is the straight line
    # beta0 + s (1, -1, -1, 1) / 2 (units 1, 3 and 2, 4 cancel pairwise along it): moving s of arc along
    # it keeps H = 0 and lands on that line (RK2 on a straight line: round-off only).
    from testbed.steering.planned_path import reconfigured
    geo = bench.geometry()
    start = np.radians(bench.START_SETS_DEG[0])
    moved, on_the_way = reconfigured(geo.unit_jacobian, start, 0.8)
    direction = np.array([1.0, -1.0, -1.0, 1.0]) / 2
    assert np.abs(np.abs((moved - start) @ direction) - 0.8) < 1e-6
    assert np.linalg.norm(moved - start - ((moved - start) @ direction) * direction) < 1e-6
    assert np.abs(geo.momentum(moved)).max() < 1e-9 and on_the_way.min() > 0.4
    # 90 deg of arc along the line is a singular set (units pairwise antiparallel): the way past it
    # dips below the plan's floor 0.05 (its samples are 0.025 rad apart, |dm/ds| ~ 1.9 there)
    assert reconfigured(geo.unit_jacobian, start, np.pi / 2 + 0.01)[1].min() < 0.05


# Case 203 of the default benchmark (seed 29, --sweep 12): f = 0.80 of the envelope, start set 0.
OUTER_CASE = {"direction": [0.14482407675874578, 0.37248920657275325, 0.9166666666666666],
              "fraction": 0.8, "start": 0, "radius": 3.7680441395948114}


def test_the_planned_path_flies_an_outer_band_slew_that_pinv_cannot(bench):
    # pinv's path asks for more than 30 deg/s near a singular set and the rate limit scales the
    # torque down; the planned path (a start moved along its fibre before the slew, null motion
    # shaped in flight) keeps exact torque and ends at the analytic H_w(T) = 0.
    pinv = bench.fly("pinv", OUTER_CASE)
    planned = bench.fly("planned", OUTER_CASE)
    assert not pinv["exact"] and pinv["torque_error_rel"] > 1e-3
    assert planned["exact"] and not planned["refused"] and planned["min_singularity_measure"] >= 0.05
    assert planned["final_momentum_error_h"] < 1e-3


def test_the_planner_refuses_a_program_beyond_the_envelope(bench):
    # 1.05 of the envelope's radius along d: no gimbal state holds the peak (the envelope is the
    # boundary of the momenta the cluster holds, momentum_gauge.py), so no path exists.
    from testbed.steering.planned_path import plan_gimbal_path
    geo, case = bench.geometry(), dict(OUTER_CASE, fraction=1.05)
    start = np.radians(bench.START_SETS_DEG[0])
    assert plan_gimbal_path(geo.unit_jacobian, start, lambda t: bench.wanted_momentum_rate(case, t),
                            bench.DURATION_S, np.radians(bench.RATE_MAX_DEG_S), max_evaluations=40) is None
