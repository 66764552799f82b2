"""CMG unit faults (testbed/systems/cmg_cluster/faults.py), their detection and isolation and
the steering on the remaining units (testbed/steering/fault_isolation.py, stage.py).

Independent numbers: the rhombus geometry of SEEDS §004 eq. (15) written out here, the support
function of the remaining units' momentum set in closed form, the conservation of the total
angular momentum, an exponential decay, and the tachometer read-outs against the truth.
"""

from __future__ import annotations

import numpy as np
import pytest

import testbed
from testbed.cli import main
from testbed.runner import prepare
from testbed.systems.cmg_cluster.momentum_envelope import remaining_cluster_surfaces, singular_momenta

ALPHA = np.radians(54.7356)
SIGNS = np.array([1.0, 1.0, -1.0, -1.0])


def rhombus(alpha=ALPHA):
    """e_i (spin at beta = 0), s_i z and g_i = s_i e_i x z of SEEDS §004, written out."""
    c, s = np.cos(alpha), np.sin(alpha)
    e = np.array([[c, s, 0], [-c, s, 0], [-c, -s, 0], [c, -s, 0]])
    z = SIGNS[:, None] * np.array([0.0, 0.0, 1.0])
    g = SIGNS[:, None] * np.cross(e, [0.0, 0.0, 1.0])
    return e, z, g


def torque_of_commands(beta, rates, omega, rotor_momentum):
    """-(h J(beta) beta' + omega x H(beta)) per sample, eq. (15)-(18) written out: (m, 3)."""
    e, z, _ = rhombus()
    spin = np.cos(beta)[..., None] * e + np.sin(beta)[..., None] * z       # (m, 4, 3)
    column = -np.sin(beta)[..., None] * e + np.cos(beta)[..., None] * z    # dH_i/dbeta_i / h
    hdot = rotor_momentum * np.einsum("mi,mia->ma", rates, column)
    momentum = rotor_momentum * spin.sum(axis=1)
    return -(hdot + np.cross(omega, momentum))


def relative_rms(delivered, wanted) -> float:
    """RMS |delivered - wanted| / RMS |wanted| over the samples (the torque_error_rel definition)."""
    return float(np.sqrt(np.mean(np.sum((delivered - wanted) ** 2, axis=1)) / np.mean(np.sum(wanted**2, axis=1))))


@pytest.mark.slow
def test_a_gimbal_stuck_mid_slew_is_isolated_and_the_slew_ends_on_three_units():
    """Validation 1: reorient_gimbal_stuck (reorient_minimax's slew, gimbal 2 stuck at t = 20 s)."""
    result = testbed.run("reorient_gimbal_stuck")
    m = result.metrics
    assert result.passed, result.checks
    assert m["isolated_unit"] == 2
    # the residual shows at the first tick after the fault (20.05 s); 3 ticks of persistence
    assert 20.0 < m["detection_time_s"] <= 20.05 + 1e-9
    assert m["isolation_time_s"] - 20.0 <= 0.15 + 1e-9
    assert m["final_attitude_error_deg"] <= 0.01
    # conservation law: only internal torques act (RK4's error, 1.0e-10 measured)
    assert m["momentum_drift_rel"] <= 1e-9

    t, law_torque = result.trace["law/torque"]
    _, rates = result.trace["allocator/gimbal_rates"]
    _, beta = result.trace["truth/gimbal_angle"]
    _, omega = result.trace["estimator/omega"]
    _, true_rates = result.trace["truth/gimbal_rate"]
    _, failed = result.trace["allocator/failed_units"]
    n = len(t)
    after = (t >= m["isolation_time_s"]) & np.all(np.isfinite(law_torque), axis=1)
    assert np.all(failed[after] == [0, 1, 0, 0])
    assert np.all(rates[after, 1] == 0.0)  # nothing asked of the stuck unit
    # the torque the three units' commands give, from eq. (15)-(18) written out here: the
    # well-conditioned remaining J (min sqrt det 0.33) delivers the demand to round-off
    delivered = torque_of_commands(beta[:n][after], rates[after], omega[:n][after], 25.0)
    wanted = law_torque[after]
    assert relative_rms(delivered, wanted) <= 1e-6  # 5.8e-9 measured; the validation asks 1e-3
    # the stuck gimbal stays put: its drive holds it to 0.05 deg/s (a physical band: the servo's
    # disturbance observer learning the gyroscopic torque once the command drops to 0)
    assert np.max(np.abs(np.degrees(true_rates[:n][t >= 20.05, 1]))) <= 0.05


def support(u, e, z, h):
    """max over the gimbal angles of u . sum_i h (cos b_i e_i + sin b_i z_i): each unit's best
    is h |(u . e_i, u . z_i)| at b_i = atan2(u . z_i, u . e_i) (closed form); returns the value
    (m,) and the maximising momentum (m, 3)."""
    a, b = u @ e.T, u @ z.T  # (m, units)
    best = np.arctan2(b, a)
    point = h * (np.cos(best)[..., None] * e + np.sin(best)[..., None] * z).sum(axis=1)
    return h * np.hypot(a, b).sum(axis=1), point


def test_the_three_unit_envelope_is_the_support_function_of_the_remaining_units():
    """Validation 2: the envelope of units 1, 3, 4 (unit 2 failed) against the support function
    of their momentum set, computed here in closed form, along 1000 directions (1e-9: both are
    a few floating-point operations on unit vectors)."""
    e, z, g = rhombus()
    keep = [0, 2, 3]
    h = 25.0
    u = np.random.default_rng(27).normal(size=(1000, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    envelope = singular_momenta(u, (1, 1, 1), g[keep], h).sum(axis=1)
    value, point = support(u, e[keep], z[keep], h)
    assert np.max(np.abs(np.einsum("ma,ma->m", envelope, u) - value)) <= 1e-9 * h
    assert np.max(np.abs(envelope - point)) <= 1e-9 * h
    # the surfaces the trace draws: 4 sign patterns of 3 units, the all-plus one the envelope
    surfaces = remaining_cluster_surfaces(g, [1], 500, h)
    assert sorted(surfaces) == [(1, -1, -1), (1, -1, 1), (1, 1, -1), (1, 1, 1)]
    # every drawn envelope point is a momentum the units can hold: u . P <= S(u) for every u
    assert np.all(surfaces[(1, 1, 1)] @ u.T <= value[None, :] + 1e-9 * h)


@pytest.mark.parametrize("fault, field, words", [
    ("[{at_s: 20, unit: 5, kind: stuck}]", "model.faults[0].unit", ("does not exist",)),
    ("[{at_s: 70, unit: 2, kind: stuck}]", "model.faults[0].at_s", ("past the run",)),
    ("[{at_s: 20, unit: 2, kind: stuck}, {at_s: 30, unit: 2, kind: motor_off}]", "model.faults[1].unit",
     ("one fault per unit",)),
    ("[{at_s: 20, unit: 2, kind: spin_down}]", "model.faults[0].time_constant_s", ("needs it",)),
    ("[{at_s: 20, unit: 2, kind: stuck, bias_deg_s: 1}]", "model.faults[0].bias_deg_s", ("not a parameter",)),
    ("[{at_s: 20, unit: 0, kind: stuck}]", "model.faults[0].unit", (">= 1",)),
    ("[{at_s: 20, unit: 2, kind: spin_down, time_constant_s: 0.001}]", "model.faults[0].time_constant_s",
     ("too short for timestep",)),
])
def test_a_bad_fault_is_refused_before_the_run(fault, field, words, capfd, tmp_path):
    out = tmp_path / "never.rrd"
    code = main(["run", "reorient_gimbal_stuck", "--set", f"model.faults={fault}", "--out", str(out)])
    captured = capfd.readouterr()
    assert code == 2, captured.err
    assert captured.err.startswith(f"error: {field}: ") and all(w in captured.err for w in words), captured.err
    assert "Traceback" not in captured.err and not out.exists()


def open_loop(faults: str, duration: float = 4.0):
    """cmg_open_loop for `duration` s with `faults`; no checks."""
    return testbed.run("cmg_open_loop", overrides=[f"model.faults={faults}", f"sim.duration_s={duration}",
                                                   "checks={}", "reference=null"])


def test_each_hardware_fault_acts_on_the_truth_and_keeps_the_momentum():
    """One run, four units, four hardware faults at t = 1 s, on the sinusoidal open-loop commands."""
    result = open_loop("[{at_s: 1, unit: 1, kind: stuck}, {at_s: 1, unit: 2, kind: motor_off},"
                       " {at_s: 1, unit: 3, kind: rate_limit, rate_limit_deg_s: 0.5},"
                       " {at_s: 1, unit: 4, kind: spin_down, time_constant_s: 2}]")
    assert result.status == "ok"
    t, rate = result.trace["truth/gimbal_rate"]
    _, command = result.trace["truth/gimbal_rate_command"]
    _, speed = result.trace["truth/rotor_rate"]
    _, code = result.trace["truth/fault"]
    late = t >= 1.2
    assert np.all(code[late] == [1, 2, 3, 4]) and np.all(code[t < 0.99] == 0)
    # stuck: the drive holds the gimbal at rest (a band: the servo's observer settling)
    assert np.max(np.abs(np.degrees(rate[late, 0]))) <= 0.01
    # motor off: the gimbal no longer follows its 2 deg/s command
    assert np.max(np.abs(np.degrees(rate[late, 1] - command[late, 1]))) > 0.5
    # lower rate limit: |rate| <= 0.5 deg/s once the servo has caught up (0.2 s), command above it;
    # a 1 % band: the feedforward servo follows the clipped command to 0.25 % (measured) while
    # its disturbance observer chases the gyroscopic torque, which the clipped rate changes
    assert np.max(np.abs(np.degrees(rate[late, 2]))) <= 0.5 * 1.01
    assert np.max(np.abs(np.degrees(command[late, 2]))) > 1.0
    # spin-down: Omega = Omega0 exp(-(t - 1) / tau), tau = 2 s (the bus and gimbal rates that
    # couple into the rotor's axis are 1e-5 of Omega)
    omega0 = 6000 * np.pi / 30
    expected = omega0 * np.exp(-(t[late] - 1.0) / 2.0)
    assert np.max(np.abs(speed[late, 3] / expected - 1.0)) <= 1e-3
    # every fault torque acts between a unit and the bus
    _, momentum = result.trace["truth/angular_momentum_world"]
    assert np.max(np.linalg.norm(momentum - momentum[0], axis=1)) <= 1e-8 * 200.0


def test_a_tachometer_fault_changes_what_the_controller_reads_not_the_truth():
    scenario = testbed.load("cmg_open_loop", ["model.faults=[{at_s: 0, unit: 2, kind: sensor_bias, bias_deg_s: 1.5},"
                                              " {at_s: 0, unit: 4, kind: sensor_dropout}]", "reference=null",
                                              "checks={}"])
    plant, pipeline, _ = prepare(scenario)
    pipeline.tick(0.0, plant)
    plant.step(10)
    read, truth = plant.actuator_state()["gimbal_rate"], plant.truth()["gimbal_rate"]
    assert read[1] - truth[1] == pytest.approx(np.radians(1.5), rel=1e-12)
    assert read[3] == 0.0 and truth[3] != 0.0
    assert read[0] == truth[0] and read[2] == truth[2]


def test_no_false_alarm_without_a_fault_and_the_shipped_slew_is_unchanged():
    """The fault-free slew with detection on: no unit isolated, and the same final attitude as
    reorient_minimax's (detection only reads; 20 s are enough to cover the slew's fastest part)."""
    result = testbed.run("reorient_gimbal_stuck", overrides=["model.faults=[]", "sim.duration_s=25", "checks={}"])
    assert result.metrics["isolated_unit"] == 0
    assert np.isnan(result.metrics["isolation_time_s"])
    _, residual = result.trace["allocator/fault_residual"]
    assert np.nanmax(residual) < 0.5  # the largest residual is under half its threshold


@pytest.mark.slow
def test_the_fault_campaigns_first_cases(tmp_path, capsys):
    """Cases 0 and 1 of reorient_fault_campaign (each `--case N` alone is its row of the full
    campaign: a case draws from its own seed) and case 0 of reorient_fault_free_campaign: each
    drawn fault is isolated on its own unit after it starts; the fault-free slew isolates nothing."""
    import json

    for case in (0, 1):
        main(["campaign", "reorient_fault_campaign", "--case", str(case), "--out", str(tmp_path / "f"), "--json"])
        row = json.loads(capsys.readouterr().out)
        assert row["status"] == "ok"
        assert row["isolated_unit"] == row["applied:model.faults.0.unit"]
        assert 0 < row["fault_isolation_delay_s"] <= 5.0
    assert main(["campaign", "reorient_fault_free_campaign", "--case", "0", "--out", str(tmp_path / "ff"),
                 "--json"]) == 0
    row = json.loads(capsys.readouterr().out)
    assert row["isolated_unit"] == 0 and row["passed"]
