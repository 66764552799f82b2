"""The accuracy guard (testbed/accuracy/): a run whose integration cannot be trusted fails or is refused.

The case is the torque-free Skylab body of scenarios/torque_free_tumble.yaml spun up to
2 rad/s, its own checks and reference removed, so that only the guard can fail it. The
independent numbers: the conservation law, L_world = R(q) I w computed in the test from the
recorded attitude and rate (scipy's Rotation), which must stay constant for a free body;
RK4's amplification on an axisymmetric body, whose transverse rate turns at a known rate; the
frequency response of the intvelocity servo's second-order loop. No false positive: short runs
of shipped CMG scenarios, a stepped run and a Gymnasium episode.
"""

from __future__ import annotations

import gymnasium
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import testbed
import testbed.gym  # noqa: F401  (registers the environments)
from testbed.cli import main
from testbed.runner import run_scenario
from testbed.scenario.loading import load_scenario

TUMBLE = ["sim.duration_s=300", "initial.omega_rad_s=[0.01, 0.02, 2]", "checks={}", "reference="]
SKYLAB_INERTIA = np.array([1.25e6, 6.9e6, 7.1e6])


def tumble(dt: float, *extra: str):
    overrides = TUMBLE + [f"sim.dt_s={dt}", f"sim.control_period_s={dt}", *extra]
    return run_scenario(load_scenario("torque_free_tumble", overrides), None, keep_data=True)


def momentum_drift(result) -> float:
    """max |L(t) - L(0)| / |L(0)| of L_world = R(q) I w, from the trace."""
    _, omega = result.trace["truth/omega"]
    _, quat = result.trace["truth/quat"]
    momentum = Rotation.from_quat(quat, scalar_first=True).apply(SKYLAB_INERTIA * omega)
    return float(np.max(np.linalg.norm(momentum - momentum[0], axis=1)) / np.linalg.norm(momentum[0]))


def test_the_two_rad_per_step_tumble_is_refused_before_it_runs(tmp_path):
    out = tmp_path / "tumble.rrd"
    argv = ["run", "torque_free_tumble", "--out", str(out)] + [a for o in TUMBLE + ["sim.dt_s=1", "sim.control_period_s=1"]
                                                               for a in ("--set", o)]
    assert main(argv) == 2
    assert not out.exists()


def test_a_drifting_run_fails_with_a_reason_naming_dt_and_keeps_its_trace(tmp_path, capsys):
    # 0.6 rad a step: under the step-angle limit, so the run goes; the drift is what fails it
    result = tumble(0.3)
    drift = momentum_drift(result)
    assert drift > 1e-6  # the conservation law, computed here, is broken: the guard must say so
    rows = {c["name"]: c for c in result.checks}
    assert not result.passed and not rows["accuracy:momentum_drift"]["passed"]
    assert "dt 0.3 s" in rows["accuracy:momentum_drift"]["reason"]
    # the guard's figure is the run's own momentum_drift_rel: within the trace sampling of the test's
    assert rows["accuracy:momentum_drift"]["value"] == pytest.approx(drift, rel=0.2)
    out = tmp_path / "tumble.rrd"
    argv = ["run", "torque_free_tumble", "--out", str(out)] + [a for o in TUMBLE + ["sim.dt_s=0.3", "sim.control_period_s=0.3"]
                                                               for a in ("--set", o)]
    assert main(argv) == 1
    assert out.exists()
    assert "accuracy:momentum_drift" in capsys.readouterr().out


def test_a_faithful_step_passes_the_guard():
    result = tumble(0.01, "sim.duration_s=60")
    assert momentum_drift(result) < 1e-9  # RK4 at 0.02 rad a step conserves L to round-off level
    assert result.passed and not [c for c in result.checks if c["name"].startswith("accuracy:")]


def test_a_scenario_relaxes_a_guard_explicitly():
    result = tumble(0.3, "accuracy.momentum_drift_rel_max=1e-3")
    assert result.passed
    assert tumble(0.3, "accuracy.enabled=false").passed


def test_a_scenario_check_on_the_metric_replaces_the_default():
    result = tumble(0.3, "checks={momentum_drift_rel: {max: 1e-3}}")
    assert result.passed and [c["name"] for c in result.checks] == ["momentum_drift_rel"]


@pytest.mark.parametrize("setting", ["accuracy.step_angle_max_rad=0", "accuracy.momentum_drift_rel_max=-1",
                                     "accuracy.enabled=maybe", "accuracy.typo=1"])
def test_bad_guard_settings_are_refused(setting):
    assert main(["check", "torque_free_tumble", "--set", setting]) == 2


def test_a_rate_that_grows_past_the_step_limit_fails_the_run():
    # a torque about the principal z axis spins the body up from 0.3 to w = 0.3 + T t / Iz = 1.99
    # rad/s in 300 s (a pure spin stays a pure spin): 0.09 rad a step at t = 0 passes the check at
    # load, 0.6 at the end is over a 0.5 rad limit, which only the run-time monitor sees
    torque, dt = 4.0e4, 0.3
    spin_up = ["initial.omega_rad_s=[0, 0, 0.3]", f"sim.dt_s={dt}", f"sim.control_period_s={dt}",
               f"pipeline.law={{type: torque_profile, offset: [0, 0, {torque}]}}",
               "pipeline.allocator={type: ideal_torque}"]
    peak = 0.3 + torque / SKYLAB_INERTIA[2] * 300.0
    result = run_scenario(load_scenario("torque_free_tumble", TUMBLE[:1] + ["checks={}", "reference="] + spin_up
                                        + ["accuracy.step_angle_max_rad=0.5"]), None)
    rows = {c["name"]: c for c in result.checks}
    assert rows["accuracy:step_angle"]["value"] == pytest.approx(peak * dt, rel=1e-3)
    assert "dt 0.3 s" in rows["accuracy:step_angle"]["reason"] and not result.passed
    relaxed = run_scenario(load_scenario("torque_free_tumble", TUMBLE[:1] + ["checks={}", "reference="] + spin_up), None)
    assert relaxed.passed  # 0.6 rad a step is under the default 0.7


def guard_rows(result) -> dict:
    return {c["name"]: c for c in result.checks if c["name"].startswith("accuracy:")}


def test_rk4s_energy_error_on_an_axisymmetric_body_is_the_guards_figure():
    # I = (1000, 1000, 2000): w_z stays 1 rad/s and (w_x, w_y) turns at lam = (Iz - Ix) / Ix w_z =
    # 1 rad/s (Euler's equations, linear here); RK4 multiplies its length by |R(i lam dt)|, R the
    # degree-4 Taylor polynomial of exp, at every step: T(n) = Iz wz^2 / 2 + Ix |w_t|^2 |R|^2n / 2.
    # Well conditioned (a product of 1000-3000 known factors): pinned to 1e-6.
    def run(dt):
        overrides = ["model.inertia_kg_m2=[1000, 1000, 2000]", "initial.omega_rad_s=[0.5, 0, 1]",
                     "sim.duration_s=300", f"sim.dt_s={dt}", f"sim.control_period_s={dt}", "checks={}", "reference="]
        return run_scenario(load_scenario("torque_free_tumble", overrides), None)

    def rk4_drift(dt):
        z = 1j * dt
        gain = abs(1 + z + z ** 2 / 2 + z ** 3 / 6 + z ** 4 / 24) ** 2
        transverse, total = 0.5 * 1000 * 0.25, 0.5 * 2000 + 0.5 * 1000 * 0.25
        return transverse * (1 - gain ** round(300 / dt)) / total

    coarse, fine = run(0.1), run(0.05)
    assert rk4_drift(0.1) > 1e-6 > rk4_drift(0.05)  # the default threshold lies between the two
    row = guard_rows(coarse)["accuracy:energy_drift"]
    assert row["value"] == pytest.approx(rk4_drift(0.1), rel=1e-6) and "dt 0.1 s" in row["reason"]
    assert not coarse.passed
    assert fine.passed and not guard_rows(fine)


def test_a_soft_servo_that_lags_its_command_fails_the_tracking_guard(tmp_path):
    # the intvelocity servo is the loop b'/c = H(s) = w_n^2 / (s^2 + 2 zeta w_n s + w_n^2): on
    # c_i = A_i sin(w_i t) it lags by |H(i w_i) - 1| A_i in steady state (rotor momentum ~0: no
    # gyroscopic torque). The guard discounts the command's change over the last two ticks,
    # at most max_j A_j w_j Tc / A_i (0.3 % here), and the bus's recoil leaves the gimbal a little
    # less inertia than the gains were set for (w_n a little higher): a band of 3 % (measured -2.2 %).
    wn, zeta, period = 3.0, 1.0, 0.01
    amplitude = np.radians([3.0, 2.0, 4.0, 2.5])
    w = 2 * np.pi * np.array([0.02, 0.031, 0.013, 0.047])  # cmg_open_loop's profile
    overrides = ["model.servo_model=intvelocity", f"model.servo_natural_frequency_rad_s={wn}",
                 "model.rotor_momentum_nms=0.001", "pipeline.allocator.phase_deg=[0, 0, 0, 0]",
                 f"sim.trace_period_s={period}", "sim.duration_s=25", "checks={}", "reference="]
    lag = np.abs(wn ** 2 / (wn ** 2 - w ** 2 + 2j * zeta * wn * w) - 1)
    result = run_scenario(load_scenario("cmg_open_loop", overrides), None)
    row = guard_rows(result)["accuracy:tracking"]
    assert row["value"] == pytest.approx(lag.max(), rel=0.03) and not result.passed
    relaxed = run_scenario(load_scenario("cmg_open_loop", overrides + ["accuracy.tracking_error_rel_max=0.25"]), None)
    assert relaxed.passed  # the study wants this servo: it says so
    out = tmp_path / "soft.rrd"
    assert main(["run", "cmg_open_loop", "--out", str(out)] + [a for o in overrides for a in ("--set", o)]) == 1
    assert out.exists()


@pytest.mark.parametrize("name", ["reorient_minimax", "cmg_open_loop"])
@pytest.mark.parametrize("duration", [1, 3])
def test_no_false_positive_on_short_runs_of_cmg_scenarios(name, duration):
    # before the slew starts (5 s) the commands are round-off (1e-12 rad/s): judged against the
    # scale floor, not against themselves
    result = testbed.run(name, overrides=[f"sim.duration_s={duration}", "checks={}", "reference="])
    assert result.status == "ok" and not guard_rows(result)


def test_no_false_positive_on_a_stepped_run_with_jumps_and_pushes():
    # random gimbal-rate jumps as big as the commands, then a body torque given at one step (an
    # external push: the momentum monitor must not judge that run)
    rng = np.random.default_rng(3)
    with testbed.Simulation("reorient_minimax", ["sim.duration_s=1", "checks={}"]) as sim:
        while sim.ticks < 10:
            sim.step({"allocator": {"gimbal_rates": rng.uniform(-0.1, 0.1, 4)}})
        sim.step({"allocator": {"body_torque": np.array([50.0, 0.0, 0.0])}})
        while sim.running:
            sim.step()
        result = sim.close()
    assert result.metrics["momentum_drift_rel"] > 1e-3  # the push changed L
    assert result.passed and not guard_rows(result)


def test_no_false_positive_on_a_gym_episode():
    env = gymnasium.make("testbed/CmgSlewGimbalRates-v0", overrides=["sim.duration_s=2"])
    env.reset(seed=1)
    env.action_space.seed(1)
    done = False
    while not done:
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())  # a random policy's jumps
        done = terminated or truncated
    result = env.unwrapped.sim.close()
    env.close()
    assert result.status == "ok" and not guard_rows(result)


def test_no_momentum_monitor_where_the_rotor_imbalance_pushes_the_bus():
    result = run_scenario(load_scenario("rotor_imbalance_jitter"), None)
    assert result.metrics["momentum_drift_rel"] > 1e-3  # the jitter's wrench is external (xfrc_applied)
    assert result.passed and not guard_rows(result)


def test_an_unbalanced_rotor_turning_too_far_a_step_is_refused(tmp_path, capsys):
    # 6000 rpm = 628 rad/s: 1.26 rad a step at dt 2 ms, which the jitter's wrench cannot resolve
    out = tmp_path / "jitter.rrd"
    assert main(["run", "rotor_imbalance_jitter", "--out", str(out), "--set", "sim.dt_s=0.002",
                 "--set", "sim.trace_period_s=0.002", "--set", "sim.estimator_period_s=0.002"]) == 2
    assert not out.exists()
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "sim.dt_s" in err[0] and "rotor speed" in err[0]
