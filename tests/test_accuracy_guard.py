"""The accuracy guard (testbed/accuracy/): a run whose integration cannot be trusted fails or is refused.

The case is the torque-free Skylab body of scenarios/torque_free_tumble.yaml spun up to
2 rad/s, its own checks and reference removed, so that only the guard can fail it. The
independent number is the conservation law: L_world = R(q) I w computed in the test from the
recorded attitude and rate (scipy's Rotation), which must stay constant for a free body.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

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
