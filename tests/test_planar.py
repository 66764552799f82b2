"""Planar AKOR regulator (issue 5): the hinge model, the loop, and each figure measured in
simulation against numbers derived here independently (hand algebra, solve_ivp)."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from testbed.systems.planar import figures as fig
from testbed.cli import main
from testbed.runner import run_scenario
from testbed.scenario.loading import load_scenario

SQ3 = np.sqrt(3.0)


@pytest.fixture(scope="module")
def akor_run():
    """planar_akor: b11 = b22 = k = 1, J = 2.5: s^2 + sqrt(3) s + 1 (roots -sqrt(3)/2 +- j/2)."""
    return run_scenario(load_scenario("planar_akor"), None, keep_data=True)


def _x(run):
    rec = run.data.recorder
    return rec.time, np.column_stack([rec["truth/angle"][:, 0], rec["truth/rate"][:, 0]])


def _continuous_loop(t_eval, x0=(0.1, 0.0)):
    """x'' = -(x + sqrt(3) x'): eq. 6 with S12 = 1, S22 = sqrt(3) worked by hand (k = 1)."""
    return solve_ivp(lambda t, x: [x[1], -x[0] - SQ3 * x[1]], (0, t_eval[-1]), x0, method="DOP853",
                     rtol=1e-12, atol=1e-14, t_eval=t_eval, dense_output=True)


def test_disturbance_input_is_exact_and_separate_from_the_control():
    """Open loop: x1 = x10 + x20 t + m0 (t-1)_+^2 / 2 + m0' (t-2)_+^3 / 6; the control motor stays 0."""
    sets = ["pipeline={}", "checks={}", "sim.duration_s=4", "model.initial_rate_rad_s=0.02",
            "model.disturbance_start_s=1", "model.ramp_start_s=2", "model.disturbance_rate_rad_s3=0.003"]
    run = run_scenario(load_scenario("planar_akor", sets), None, keep_data=True)
    rec = run.data.recorder
    t = rec.time
    expected = 0.1 + 0.02 * t + 0.01 * np.maximum(t - 1, 0) ** 2 / 2 + 0.003 * np.maximum(t - 2, 0) ** 3 / 6
    assert np.max(np.abs(rec["truth/angle"][:, 0] - expected)) < 1e-12
    torque = 2.5 * (0.01 * (t >= 1) + 0.003 * np.maximum(t - 2, 0))
    assert rec["truth/disturbance_torque"][:, 0] == pytest.approx(torque, abs=1e-12)
    assert np.all(rec["truth/control_torque"] == 0.0)


@pytest.mark.slow
def test_law_torque_is_J_u_and_the_loop_follows_the_continuous_one(akor_run):
    rec = akor_run.data.recorder
    torque, u = rec["law/torque"][:-1], rec["law/u"][:-1, 0]  # the last sample is truth only
    assert torque[:, 2] == pytest.approx(2.5 * u, rel=1e-14)
    assert np.all(torque[:, :2] == 0.0)
    assert rec["truth/control_torque"][:-1, 0] == pytest.approx(2.5 * u, rel=1e-14)
    t, x = _x(akor_run)
    free = t <= 20.0
    ref = _continuous_loop(t[free]).y.T
    # the 1 ms zero-order hold is the only difference: O(Tc) of the 0.1 rad offset
    assert np.max(np.abs(x[free] - ref)) < 3e-5


@pytest.mark.slow
def test_every_check_of_planar_akor_passes(akor_run):
    assert akor_run.status == "ok"
    assert akor_run.checks and all(c["passed"] for c in akor_run.checks), akor_run.checks


@pytest.mark.slow
def test_eta_and_settling_time_against_hand_values(akor_run):
    m = akor_run.metrics
    assert m["akor_eta_formula_1_s"] == pytest.approx(SQ3 / 2, rel=1e-12)
    assert m["akor_eta_sim_1_s"] == pytest.approx(SQ3 / 2, rel=2e-3)
    # 95 % time of the continuous loop, found on solve_ivp's dense output
    sol = _continuous_loop(np.linspace(0, 20, 20001))
    grid = np.linspace(0, 20, 200_001)
    outside = np.nonzero(np.abs(sol.sol(grid)[0]) > 0.005)[0][-1]
    assert m["akor_settling_time_s"] == pytest.approx(grid[outside], rel=1e-3)
    assert m["akor_settling_rule_error_rel"] == pytest.approx(3 / (SQ3 / 2) / grid[outside] - 1, abs=1e-3)


@pytest.mark.slow
def test_steady_errors_against_hand_values(akor_run):
    """k S12 = 1, k S22 = sqrt(3): ER0 = (1, 0), ER1 = (-sqrt(3), 1); x(60) = m0'(ER0 20 + ER1) + ER0 m0."""
    m = akor_run.metrics
    assert m["akor_static_angle_error_rad"] == pytest.approx(0.01, rel=1e-5)
    assert m["akor_er1_angle_sim"] == pytest.approx(-SQ3, rel=1e-3)
    assert m["akor_er1_rate_sim"] == pytest.approx(1.0, rel=1e-3)
    assert m["akor_eq16_er1_sign_matches"] == 0.0  # printed +sqrt(3): the sign is wrong
    t, x = _x(akor_run)
    assert x[-1] == pytest.approx([0.001 * (20 - SQ3) + 0.01, 0.001], rel=1e-4)


@pytest.mark.slow
def test_peak_power_against_a_brute_force_maximum(akor_run):
    """P = u x2 with u = -(x1 + sqrt(3) x2), maximised on a fine solve_ivp grid (eq. 18)."""
    grid = np.linspace(0, 6, 600_001)
    x1, x2 = _continuous_loop(np.linspace(0, 6, 601)).sol(grid)
    peak = np.max(-(x1 + SQ3 * x2) * x2) / 0.1**2
    assert akor_run.metrics["akor_power_peak_per_x10sq"] == pytest.approx(peak, rel=1e-3)


@pytest.mark.slow
def test_double_root_eta_gap_is_the_sampling_split_shrinking_as_sqrt_Tc():
    """b22 = 2 sqrt(b11/k): double root at -1 = -(k b11)^(1/4) (eq. 17). The zero-order hold
    splits it into real roots about -1 +- sqrt(Tc/2): the gap to eta_max halves when Tc / 4."""
    gaps = []
    for tc in (1e-3, 2.5e-4):
        sets = ["pipeline.law.beta22=2", "sim.duration_s=10", "model.disturbance_rad_s2=0",
                "model.disturbance_rate_rad_s3=0", f"sim.dt_s={tc}", f"sim.control_period_s={tc}", "checks={}"]
        m = run_scenario(load_scenario("planar_akor", sets), None).metrics
        assert m["akor_eta_formula_1_s"] == pytest.approx(1.0, rel=1e-12)
        assert m["akor_root_kind"] == 0.0
        gaps.append(1.0 - m["akor_eta_over_eta_max"])
    assert gaps[0] == pytest.approx(np.sqrt(1e-3 / 2), rel=0.1)
    assert gaps[0] / gaps[1] == pytest.approx(2.0, rel=0.1)


def test_identify_poles_on_an_analytic_decay():
    t = np.arange(0, 30, 0.01)
    x = np.column_stack([np.exp(-0.3 * t) * np.cos(2 * t), np.exp(-0.3 * t) * (-0.3 * np.cos(2 * t) - 2 * np.sin(2 * t))])
    poles = fig.identify_poles(t, x)
    assert sorted(poles.imag) == pytest.approx([-2, 2], abs=1e-9)
    assert poles.real == pytest.approx([-0.3, -0.3], abs=1e-9)
    assert fig.settling_time(t, np.exp(-t), 0.0) == pytest.approx(np.log(20), abs=1e-4)
    assert fig.peak(t, -(t - 1.234) ** 2)[0] == pytest.approx(1.234, abs=1e-12)


@pytest.mark.parametrize("override, field", [
    ("pipeline.law.k=0", "pipeline.law.k"),
    ("pipeline.law.beta11=0", "pipeline.law.beta11"),
    ("pipeline.law.beta11=-1", "pipeline.law.beta11"),
    ("pipeline.law.beta22=-0.1", "pipeline.law.beta22"),
    ("model.inertia_kg_m2=0", "model.inertia_kg_m2"),
    ("initial.omega_deg_s=[0, 0, 1]", "initial"),
    ("model.system=satellite", "model"),
])
def test_bad_input_is_one_line_exit_2_and_no_file(override, field, tmp_path, capsys):
    out = tmp_path / "x.rrd"
    assert main(["run", "planar_akor", "--set", override, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and field in err[0]
    assert not out.exists()
