"""Issue 4: the Lebedev one-gyro estimator and law as pipeline stages, their scenarios, bad input.

Independent numbers: the paper's gain l and the SEEDS §000 measurements, a solve_ivp simulation
of the start-up phase, the analytic bias offset -b / gamma, conservation of angular momentum.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from testbed.cli import main
from testbed.runner import prepare, run_scenario
from testbed.scenario import load_scenario
from testbed.systems.cmg_rhombus.reduced_model import CmgMassModel

SKYLAB = np.array([1.25e6, 6.9e6, 7.1e6])
DEG = np.pi / 180


@pytest.fixture(scope="module")
def spinup():
    return run_scenario(load_scenario("lebedev_spinup_ideal"), None, keep_data=True)


def _at(run, key, t):
    rec = run.data.recorder
    return rec[key][int(np.argmin(np.abs(rec.time - t)))]


def test_paper_gain_from_the_scenario():
    _, pipeline, _ = prepare(load_scenario("lebedev_spinup_ideal"))
    l = pipeline.estimator.l
    # The paper prints l = (-3.62, -37.8, 41.91): two components to 0.01, the middle one to three
    # significant figures (it is -37.774, SEEDS §000), so that one is held to its printed 0.05.
    assert l[[0, 2]] == pytest.approx([-3.62, 41.91], abs=0.01)
    assert l[1] == pytest.approx(-37.8, abs=0.05)
    assert l == pytest.approx([-3.622, -37.774, 41.916], abs=0.01)  # SEEDS' own reproduction


def test_spinup_reaches_the_paper_spin_as_measured_in_seeds(spinup):
    assert spinup.passed, spinup.checks
    # SEEDS §000: w(600 s) = (0.0002, 0.0016, 0.998) deg/s, within 1e-6 deg/s at 700 s, 1e-10 at 800 s
    assert _at(spinup, "truth/omega", 600.0) / DEG == pytest.approx([0.0002, 0.0016, 0.998], abs=1.5e-3)
    assert np.linalg.norm(_at(spinup, "truth/omega", 700.0) / DEG - [0, 0, 1]) < 1e-5
    assert np.linalg.norm(_at(spinup, "truth/omega", 800.0) / DEG - [0, 0, 1]) < 1e-9
    # Fig. 2 counterpart: no torque in the start-up phase, then M = I k z
    rec = spinup.data.recorder
    startup = rec.time < 150.0
    assert np.all(rec["law/torque"][startup] == 0.0)
    i = int(np.argmin(np.abs(rec.time - 200.0)))
    z = rec["estimator/z"][i]
    assert rec["law/torque"][i] == pytest.approx(SKYLAB * -1.0 * z, rel=1e-12)


def test_estimator_sees_only_the_gyro_and_its_error_follows_the_observer(spinup):
    """Would fail if the controller were handed the truth: the estimator gets y and stamp only,
    and its start-up estimate equals an independent continuous simulation of body + observer
    (3.1) fed with p . w, not the true rate."""
    from testbed.recorder import Recorder
    from testbed.runner import _loop

    scenario = load_scenario("lebedev_spinup_ideal", ["sim.duration_s=1"])
    plant, pipeline, _ = prepare(scenario)
    seen = []
    original = pipeline.estimator.estimate
    pipeline.estimator.estimate = lambda t, m, c: seen.append((set(m), set(c))) or original(t, m, c)
    _loop(plant, pipeline, Recorder(100), 20, 1, scenario.sim, None)
    assert len(seen) == 20 and all(m == {"y", "stamp"} for m, _ in seen)
    assert all(c <= {"body_torque"} for _, c in seen)

    est = pipeline.estimator
    l, A, p, W = est.l, est.observer.A, est.observer.C, est.observer.spin_rate
    I = SKYLAB

    def rhs(t, s):
        w, z = s[:3], s[3:]
        dw = np.array([(I[1] - I[2]) * w[1] * w[2] / I[0], (I[2] - I[0]) * w[2] * w[0] / I[1],
                       (I[0] - I[1]) * w[0] * w[1] / I[2]])
        return np.concatenate([dw, A @ z + l * (p @ w - p[2] * W - p @ z)])

    sol = solve_ivp(rhs, (0, 150), np.r_[np.array([0.25, -0.25, 0]) * DEG, 0, 0, 0], method="DOP853",
                    rtol=1e-10, atol=1e-14, dense_output=True)
    for t in (100.0, 145.0):
        w, z = sol.sol(t)[:3], sol.sol(t)[3:]
        error_ref = np.linalg.norm(z + [0, 0, W] - w) / DEG
        rec = spinup.data.recorder
        i = int(np.argmin(np.abs(rec.time - t)))
        error_run = np.linalg.norm(rec["estimator/z"][i] + [0, 0, W] - rec["truth/omega"][i]) / DEG
        assert error_run == pytest.approx(error_ref, rel=0.1)
        assert error_run > 0.05  # a truth-fed estimator would show 0
    assert spinup.metrics["estimation_error_startup_deg_s"] > 10.0
    assert spinup.metrics["estimation_error_final_deg_s"] < 1e-10


def test_bias_offsets_the_spin_by_minus_b_over_gamma():
    """Steady state of (4.6)-(4.7) with y = p . w + b: w = (0, 0, Omega - b / gamma), z = 0 (README)."""
    run = run_scenario(load_scenario("lebedev_gyro_bias"), None)
    scenario = load_scenario("lebedev_gyro_bias")
    _, sensor = scenario.stages["sensor"]
    expected = -sensor.bias_rad_s / sensor.axis[2] / DEG
    assert run.metrics["spin_rate_offset_deg_s"] == pytest.approx(expected, rel=1e-6)
    assert run.metrics["transverse_rate_steady_deg_s"] < 1e-8
    assert run.passed


@pytest.mark.parametrize("name", ["lebedev_detumble_ideal", "lebedev_gyro_noise"])
def test_detumble_and_noise_scenarios_pass(name):
    run = run_scenario(load_scenario(name), None)
    assert run.status == "ok" and run.passed, run.checks


def test_noise_is_reproducible_bit_for_bit():
    a, b = (run_scenario(load_scenario("lebedev_gyro_noise", ["sim.duration_s=200"]), None, keep_data=True)
            for _ in range(2))
    assert np.array_equal(a.data.recorder["truth/omega"], b.data.recorder["truth/omega"])


def test_flagship_cmg_spinup_conserves_momentum():
    run = run_scenario(load_scenario("lebedev_spinup_cmg"), None, keep_data=True)
    assert run.status == "ok" and run.passed, run.checks
    rec = run.data.recorder
    # the locked inertia at the final gimbal angles, from the reduced model's mass properties
    plant, _, _ = prepare(load_scenario("lebedev_spinup_cmg"))
    inertia = CmgMassModel.from_model(plant.model).system_inertia(rec["truth/gimbal_angle"][-1])
    # zero total momentum: the cluster ends holding -I w = -Iz Omega e_z
    H = rec["truth/cmg_momentum"][-1]
    assert H == pytest.approx(-inertia @ rec["truth/omega"][-1], abs=1e-3)
    assert H[2] == pytest.approx(-7100.0 * DEG, rel=1e-4)


@pytest.mark.parametrize("override, field", [
    ("pipeline.law.gains_per_s=[1, -1, -1]", "pipeline.law.gains_per_s"),
    ("pipeline.estimator.poles_per_s=[0.0, -0.1, -0.1]", "pipeline.estimator.poles_per_s"),
    ("pipeline.sensor.sample_period_s=0.07", "pipeline.sensor.sample_period_s"),
    ("pipeline.sensor.axis=[1, 0, 0]", "pipeline.sensor.axis"),
    ("pipeline.sensor.axis=[0.6, 0.6, 0.6]", "pipeline.sensor.axis"),
    ("pipeline.sensor={type: none}", "pipeline.sensor.type"),
    ("pipeline.law.spin_rate_deg_s=0", "pipeline.law.spin_rate_deg_s"),
])
def test_bad_input_exits_2_with_one_line(override, field, tmp_path, capsys):
    out = tmp_path / "x.rrd"
    assert main(["run", "lebedev_spinup_ideal", "--out", str(out), "--set", override]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and field in err
    assert not out.exists()
