"""The steering study (bench/steering_study.py): its slews are what its docstring and docs/theory/steering.md
say, and with its gimbal limits (--limits) every law honours them on study slews (violations = 0)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from testbed.guidance.program_trajectory import ProgramTrajectory
from testbed.scenario.loading import parse
from testbed.steering import STEERING_LAWS
from testbed.systems.cmg_cluster.arrays import rhombus_axes
from testbed.systems.cmg_cluster.cluster import ClusterGeometry

SCRIPT = Path(__file__).resolve().parents[1] / "bench" / "steering_study.py"


def study():
    spec = importlib.util.spec_from_file_location("steering_study", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_study_slews_are_random_rest_to_rest_slews_as_described():
    module = study()
    slews = module.slews(200)
    axes = np.array([s["axis"] for s in slews])
    angles = np.array([s["angle_deg"] for s in slews])
    np.testing.assert_allclose(np.linalg.norm(axes, axis=1), 1.0, atol=1e-12)
    assert np.all((angles >= 30) & (angles <= 150))
    # Uniform on the sphere <=> z uniform on [-1, 1] (Archimedes) and the azimuth uniform on
    # [0, 2 pi); the angle uniform on [30, 150] deg. Kolmogorov-Smirnov on the 200 draws.
    azimuth = np.mod(np.arctan2(axes[:, 1], axes[:, 0]), 2 * np.pi)
    for sample, low, width in ((axes[:, 2], -1, 2), (azimuth, 0, 2 * np.pi), (angles, 30, 120)):
        assert stats.kstest(sample, "uniform", args=(low, width)).pvalue > 0.01
    assert module.slews(200) == slews and module.slews(5) == slews[:5]   # the same slews every time


def test_study_slews_have_one_peak_rate_and_peak_momentum_about_two_h():
    """The cubic rest-to-rest program peaks at 1.5 angle / T at T/2: with T proportional to the
    angle that is 1.5 x 60 / 40 = 2.25 deg/s for every slew; |I w*| there is about 2 h."""
    module = study()
    case = module.study_cases(1, ["minimax"])[0].data
    inertia = np.diag(case["model"]["inertia_kg_m2"])
    h = case["model"]["rotor_momentum_nms"]
    for s in module.slews(200):
        T = s["duration_s"]
        program = ProgramTrajectory.eigen_axis_slew([1, 0, 0, 0], s["axis"], np.radians(s["angle_deg"]), T)
        rate = program.rate(T / 2)
        assert np.degrees(np.linalg.norm(rate)) == pytest.approx(2.25, rel=1e-9)
        assert 1.5 <= np.linalg.norm(inertia @ rate) / h <= 2.4
        assert s["sim_s"] >= module.START_S + T + module.SETTLE_S and s["sim_s"] == round(s["sim_s"])


def test_study_cases_fly_the_slews_from_the_zero_momentum_set_with_every_law():
    module = study()
    laws = list(STEERING_LAWS)
    slews = module.slews(3)
    cases = module.study_cases([2], laws, with_limits=True)
    assert [c.derived for c in cases] == [{"slew": 2, "law": law} for law in laws]
    assert [c.values for c in cases] == [{"pipeline.allocator.type": law} for law in laws]
    for case in cases:
        scenario = parse(case.data, case.source)   # valid as a scenario, limits included
        law, allocator = case.data["pipeline"]["law"], case.data["pipeline"]["allocator"]
        assert (law["axis"], law["angle_deg"], law["duration_s"]) == (
            slews[2]["axis"], slews[2]["angle_deg"], slews[2]["duration_s"])
        assert allocator["type"] == case.derived["law"] and allocator["gimbal_acceleration_max_deg_s2"] == 200
        assert case.data["sim"]["duration_s"] == slews[2]["sim_s"] and not case.data["checks"]
        assert scenario is not None
    model = cases[0].data["model"]
    e, g, _ = rhombus_axes(np.radians(model["alpha_deg"]))
    cluster = ClusterGeometry(g, e, np.ones(4), 1.0)
    np.testing.assert_allclose(cluster.momentum(np.radians(model["gimbal_angles_deg"])), 0.0, atol=1e-15)


@pytest.mark.slow
def test_every_law_honours_the_study_limits_on_study_slews():
    """Slew 0 takes plain min-max into a singular set and to a stop; slew 2 is a short one."""
    module = study()
    laws = list(STEERING_LAWS)
    rows = module.run_study(module.study_cases([0, 2], laws, with_limits=True), workers=2)
    assert len(rows) == 2 * len(laws)
    for row in rows:
        assert row["status"] == "ok", row
        for key in module.VIOLATIONS:
            assert row[key] == 0, (row["law"], row["slew"], key)
        assert row["peak_gimbal_acceleration_deg_s2"] <= module.ACCELERATION_MAX_DEG_S2 * (1 + 1e-9)
    # the limits were met, not idle: some law ran at the acceleration limit and came to a stop
    assert max(r["peak_gimbal_acceleration_deg_s2"] for r in rows) == pytest.approx(module.ACCELERATION_MAX_DEG_S2)
    assert min(r["min_gimbal_angle_margin_deg"] for r in rows) < 0.01


def test_study_table_counts_and_medians_from_rows_written_and_read_back(tmp_path):
    """Six hand-made rows (two laws, three slews) through write_csv and read_rows: the counts,
    medians, maxima and per-slew ratios the docs' tables show, worked out by hand."""
    module = study()
    rows = []
    for slew, (m_pinv, m_minimax, rate_pinv, rate_minimax) in enumerate(
            ((1.2, 5e-4, 4.0, 30.0), (0.9, 0.3, 5.0, 4.0), (0.1, 2e-3, 8.0, 6.0))):
        for law, m, rate in (("pinv", m_pinv, rate_pinv), ("minimax", m_minimax, rate_minimax)):
            rows.append({"case": len(rows), "slew": slew, "law": law, "status": "ok",
                         "min_singularity_measure": m, "peak_gimbal_rate_deg_s": rate,
                         "torque_error_rel": 0.01 * slew, "final_attitude_error_deg": 1e-3 * (slew + 1),
                         "peak_gimbal_acceleration_deg_s2": 100.0, "rate_limit_violations": 0.0,
                         "gimbal_acceleration_violations": float(law == "minimax"),
                         "gimbal_angle_limit_violations": 0.0})
    path = module.write_csv(tmp_path / "study.csv", rows, ["slew", "law"])
    back = module.read_rows(path)
    lines = module.table(back, ["pinv", "minimax"]).splitlines()
    assert lines[2] == "| pinv | 0 of 3 | 0.1 | 5 / 8 | 0.01 / 0.02 | 0.002 / 0.003 | 0 | 0 / 0 / 0 |"
    assert lines[3] == "| minimax | 1 of 3 | 0.0005 | 6 / 30 | 0.01 / 0.02 | 0.002 / 0.003 | 0 | 0 / 3 / 0 |"
    # minimax / pinv per slew: 7.5, 0.8, 0.75 (median 0.8); slews where minimax stays >= 1e-3: 1, 2
    ratios = module.peak_rate_ratios(back, ["pinv", "minimax"]).splitlines()
    assert ratios[0].endswith("(2) |") and ratios[3] == "| minimax | 0.8 | 0.775 |"
