"""Issue 4: the Lebedev one-gyro estimator and law as pipeline stages, their scenarios, bad input.

Independent numbers: the paper's gain l and the SEEDS §000 measurements, solve_ivp simulations
of the start-up phase and of the whole continuous loop (and the sampled loop's convergence to it
as the control period shrinks), the analytic bias offset -b / gamma, conservation of angular
momentum. Whole-scenario runs are marked slow.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from testbed.cli import main
from testbed.runner import prepare, run_scenario
from testbed.scenario.loading import load_scenario
from testbed.systems.cmg_cluster.reduced_model import CmgMassModel

SKYLAB = np.array([1.25e6, 6.9e6, 7.1e6])
DEG = np.pi / 180


# The paper's example as it shipped before issue 16 (the configuration the measured ratios below
# describe): one rate of 0.05 s, the gyro sample held over the period, no reference.
HELD_Y = ["sim.dt_s=0.05", "sim.control_period_s=0.05", "sim.trace_period_s=0.5", "reference=",
          "pipeline.estimator.measurement_hold=zero_order", "pipeline.estimator.max_substep_s=0.05",
          "checks={spin_error_final_deg_s: {max: 1.0e-3}, estimation_error_final_deg_s: {max: 1.0e-4}, "
          "estimation_error_startup_deg_s: {min: 0.01}}"]


@pytest.fixture(scope="module")
def spinup():
    return run_scenario(load_scenario("lebedev_spinup_ideal", HELD_Y), None, keep_data=True)


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


def _paper_loop_continuous(t_end, startup_s=150.0):
    """The section-6 example as the paper states it, continuous in time (SEEDS §000): Euler's
    equations (1.2) with ideal torques; on [0, t*] the body is free and the linear observer (3.1)
    z' = A z + l (y - C z) runs from z = 0; then observer (4.6) with F(z) + u and the law (4.7)
    M = I k z. The gain is Ackermann's observer formula l = theta(A) W^-1 e3, W = [C; CA; CA^2],
    theta(s) = (s + 0.1)^3, computed here. solve_ivp DOP853; returns (l, dense solution after t*)."""
    spin = np.deg2rad(1.0)  # Omega
    p = np.ones(3) / np.sqrt(3.0)
    k = np.array([-1.0, -1.0, -1.0])
    a = np.array([(SKYLAB[1] - SKYLAB[2]) / SKYLAB[0], (SKYLAB[2] - SKYLAB[0]) / SKYLAB[1],
                  (SKYLAB[0] - SKYLAB[1]) / SKYLAB[2]])
    A = np.array([[0.0, a[0] * spin, 0.0], [a[1] * spin, 0.0, 0.0], [0.0, 0.0, 0.0]])
    shifted = A + 0.1 * np.eye(3)
    l = shifted @ shifted @ shifted @ np.linalg.solve(np.vstack([p, p @ A, p @ A @ A]), [0.0, 0.0, 1.0])

    def rhs(_t, s, closed):
        w, z = s[:3], s[3:]
        u = k * z if closed else np.zeros(3)  # M / I
        dw = a * np.array([w[1] * w[2], w[2] * w[0], w[0] * w[1]]) + u
        dz = A @ z + l * (p @ w - p[2] * spin - p @ z)
        if closed:
            dz = dz + a * np.array([z[1] * z[2], z[0] * z[2], z[0] * z[1]]) + u
        return np.concatenate([dw, dz])

    opts = dict(method="DOP853", rtol=1e-11, atol=1e-16)
    s0 = np.r_[np.array([0.25, -0.25, 0.0]) * DEG, 0.0, 0.0, 0.0]
    start = solve_ivp(rhs, (0.0, startup_s), s0, args=(False,), **opts)
    loop = solve_ivp(rhs, (startup_s, t_end), start.y[:, -1], args=(True,), dense_output=True, **opts)
    assert start.success and loop.success
    return l, loop


@pytest.mark.slow
def test_spinup_reaches_the_paper_spin_as_measured_in_seeds(spinup):
    assert spinup.passed, spinup.checks
    # SEEDS §000: w(600 s) = (0.0002, 0.0016, 0.998) deg/s, within 1e-6 deg/s at 700 s, 1e-10 at 800 s.
    # The continuous paper loop gives (2.168e-4, 1.59992e-3, 0.998177) deg/s at 600 s: the
    # SEEDS values to their printed digits.
    l, loop = _paper_loop_continuous(600.0)
    _, pipeline, _ = prepare(load_scenario("lebedev_spinup_ideal"))
    assert pipeline.estimator.l == pytest.approx(l, rel=1e-9)
    target = np.array([0.0, 0.0, 1.0])
    ref = loop.sol(600.0)[:3] / DEG - target  # deviation x = w - (0, 0, Omega), deg/s
    assert np.all(np.abs(ref + target - [0.0002, 0.0016, 0.998]) <= [5e-5, 5e-5, 5e-4])  # half a last digit

    # The scenario samples y and holds it (and u) over the 0.05 s control period; in the slow
    # phase after t* that changes the decay of the observer's slow mode, so at 600 s the
    # sampled loop's deviation is larger than the continuous one by about the same factor in
    # every component (measured 1.449, 1.438, 1.439) and points the same way: the ratios
    # x1 / x2 and x3 / x2 agree with the continuous loop's (measured to 0.83 % and 0.09 %).
    def deviation(run):
        rec = run.data.recorder
        i = int(np.argmin(np.abs(rec.time - 600.0)))
        assert rec.time[i] == pytest.approx(600.0, abs=1e-9)
        return rec["truth/omega"][i] / DEG - target

    x = {0.05: deviation(spinup)}
    assert spinup.data.scenario.sim.control_period_s == 0.05
    assert x[0.05] / x[0.05][1] == pytest.approx(ref / ref[1], rel=0.015)
    assert np.all((x[0.05] - ref) / ref > 0.3) and np.all((x[0.05] - ref) / ref < 0.6)
    # ... and that deviation vanishes as the period shrinks: runs at 0.025 and 0.0125 s, and
    # the deviation's expansion c1 h + c2 h^2 removed (Richardson: (8 x(h/4) - 6 x(h/2) + x(h)) / 3)
    # lands on the continuous loop. Measured: 45 %, 17 %, 7.5 % above it at 0.05, 0.025,
    # 0.0125 s; the extrapolation within 0.74 %, 0.70 %, 0.71 % per component.
    for h in (0.025, 0.0125):
        x[h] = deviation(run_scenario(load_scenario("lebedev_spinup_ideal", HELD_Y + [
            f"sim.dt_s={h}", f"sim.control_period_s={h}", "sim.duration_s=601"]), None, keep_data=True))
    gaps = [np.abs(x[h] - ref) for h in (0.05, 0.025, 0.0125)]
    assert np.all(gaps[1] < 0.5 * gaps[0]) and np.all(gaps[2] < 0.5 * gaps[1])
    extrapolated = (8 * x[0.0125] - 6 * x[0.025] + x[0.05]) / 3
    assert extrapolated == pytest.approx(ref, rel=0.02)

    assert np.linalg.norm(_at(spinup, "truth/omega", 700.0) / DEG - [0, 0, 1]) < 1e-5
    assert np.linalg.norm(_at(spinup, "truth/omega", 800.0) / DEG - [0, 0, 1]) < 1e-9
    # Fig. 2 counterpart: no torque in the start-up phase, then M = I k z
    rec = spinup.data.recorder
    startup = rec.time < 150.0
    assert np.all(rec["law/torque"][startup] == 0.0)
    i = int(np.argmin(np.abs(rec.time - 200.0)))
    z = rec["estimator/z"][i]
    assert rec["law/torque"][i] == pytest.approx(SKYLAB * -1.0 * z, rel=1e-12)


@pytest.mark.slow
def test_estimator_sees_only_the_gyro_and_its_error_follows_the_observer(spinup):
    """Would fail if the controller were handed the truth: the estimator gets y and stamp only,
    and its start-up estimate equals an independent continuous simulation of body + observer
    (3.1) fed with p . w, not the true rate."""
    from testbed.recording.recorder import Recorder
    from testbed.run_core.loop import run_ticks
    from testbed.run_core.timing import Timing

    scenario = load_scenario("lebedev_spinup_ideal", HELD_Y + ["sim.duration_s=1"])
    plant, pipeline, _ = prepare(scenario)
    seen = []
    original = pipeline.estimator.estimate
    pipeline.estimator.estimate = lambda t, m, c: seen.append((set(m), set(c))) or original(t, m, c)
    run_ticks(plant, pipeline, Recorder(100), 0, 20, Timing.of(scenario.sim))
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


@pytest.mark.slow
def test_bias_offsets_the_spin_by_minus_b_over_gamma():
    """Steady state of (4.6)-(4.7) with y = p . w + b: w = (0, 0, Omega - b / gamma), z = 0 (docs/theory/lebedev.md)."""
    run = run_scenario(load_scenario("lebedev_gyro_bias"), None)
    scenario = load_scenario("lebedev_gyro_bias")
    _, sensor = scenario.stages["sensor"]
    expected = -sensor.bias_rad_s / sensor.axis[2] / DEG
    assert run.metrics["spin_rate_offset_deg_s"] == pytest.approx(expected, rel=1e-6)
    assert run.metrics["transverse_rate_steady_deg_s"] < 1e-8
    assert run.passed


@pytest.mark.slow
@pytest.mark.parametrize("name", ["lebedev_detumble_ideal", "lebedev_gyro_noise"])
def test_detumble_and_noise_scenarios_pass(name):
    run = run_scenario(load_scenario(name), None)
    assert run.status == "ok" and run.passed, run.checks


def test_noise_is_reproducible_bit_for_bit():
    a, b = (run_scenario(load_scenario("lebedev_gyro_noise", ["sim.duration_s=200"]), None, keep_data=True)
            for _ in range(2))
    assert np.array_equal(a.data.recorder["truth/omega"], b.data.recorder["truth/omega"])


@pytest.mark.slow
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
