"""Variable-speed CMGs: the weighted law (testbed/steering/variable_speed.py) and the allocator
`vscmg` (testbed/systems/cmg_cluster/vscmg_allocator.py).

Independent numbers: the momentum rate Q eta recomputed here from the rhombus geometry of
SEEDS §004 eq. (15) with variable rotor speeds, numpy's least squares, the rotors' speed range
and the conservation of the total angular momentum.
"""

from __future__ import annotations

import numpy as np
import pytest

import testbed
from testbed.cli import main
from testbed.steering.variable_speed import variable_speed_steering
from test_faults import relative_rms, rhombus

H = 20.0
OMEGA = 6000 * np.pi / 30
JS = H / OMEGA


def columns(beta, speeds):
    """D (gimbal mode, Js W_i t_i) and C (wheel mode, Js s_i), (3, 4) each, eq. (15) written out."""
    e, z, _ = rhombus()
    spin = np.cos(beta)[:, None] * e + np.sin(beta)[:, None] * z
    transverse = -np.sin(beta)[:, None] * e + np.cos(beta)[:, None] * z
    return (JS * speeds[:, None] * transverse).T, (JS * spin).T


@pytest.mark.parametrize("beta_deg", [[45, -45, -45, 45], [0, 0, 0, 0], [90, 90, 90, 90], [10, -30, 50, 20]])
def test_the_weighted_law_gives_the_demanded_momentum_rate_even_at_a_singular_set(beta_deg):
    """beta = 0 and 90 deg are singular sets of the gimbals alone (rank 1 and 2): the wheels fill in.
    The least-squares residual of Q eta = H' at round-off (Q has rank 3: its singular values are
    >= Js, 0.03, against |H'| = 1.7 N m)."""
    beta = np.radians(beta_deg)
    d, c = columns(beta, np.full(4, OMEGA))
    hdot = np.array([1.0, -0.5, 1.3])
    result = variable_speed_steering(d, c, hdot, H, wheel_weight=1e4, decay=100.0)
    eta = np.concatenate([result.wheel_accelerations, result.gimbal_rates])
    q = np.hstack([c, d])
    assert np.linalg.norm(q @ eta - hdot) <= 1e-12 * np.linalg.norm(hdot) * np.linalg.cond(q)
    assert result.scale == 1.0
    # the weighted minimum norm: eta = W Q^T y for some y (numpy's least squares finds y)
    weights = np.concatenate([np.full(4, 1e4 * result.wheel_weight), np.ones(4)])
    y = np.linalg.lstsq(q.T * weights[:, None], eta, rcond=None)[0]
    assert np.allclose(weights * (q.T @ y), eta, rtol=0, atol=1e-10 * np.abs(eta).max())


def test_far_from_a_singular_set_the_law_is_the_gimbals_pseudo_inverse():
    """At the zero-momentum set delta = det(J J^T) = 1.78 and mu = 100: exp(-mu delta) = 6e-78, no wheel mode."""
    beta = np.radians([45, -45, -45, 45])
    d, c = columns(beta, np.full(4, OMEGA))
    hdot = np.array([0.3, 0.2, -0.4])
    result = variable_speed_steering(d, c, hdot, H, wheel_weight=1e4, decay=100.0)
    assert np.allclose(result.gimbal_rates, np.linalg.pinv(d) @ hdot, rtol=1e-9, atol=0)
    assert np.max(np.abs(result.wheel_accelerations)) <= 1e-60


def delivered_torque(result, tc=0.05):
    """-(D b' + C W') - w x H per control sample from the trace, W' from the speed commands."""
    t, wanted = result.trace["law/torque"]
    _, rates = result.trace["allocator/gimbal_rates"]
    _, command = result.trace["allocator/rotor_speeds"]
    _, beta = result.trace["truth/gimbal_angle"]
    _, speeds = result.trace["truth/rotor_rate"]
    _, omega = result.trace["estimator/omega"]
    n = len(t)
    previous = np.vstack([speeds[:1], command[:-1]])
    accelerations = (command - previous) / tc
    out = np.empty((n, 3))
    for k in range(n):
        d, c = columns(beta[k], speeds[k])
        momentum = c @ speeds[k]  # sum_i Js W_i s_i
        out[k] = -(d @ rates[k] + c @ accelerations[k]) - np.cross(omega[k], momentum)
    keep = np.all(np.isfinite(wanted), axis=1)
    return wanted[keep], out[keep]


@pytest.mark.slow
def test_the_variable_speed_cluster_steers_out_of_a_singular_set():
    """Validation 3: reorient_near_singular's slew started at beta = 0, where the gimbals alone have
    rank 1 (sqrt det(J J^T) = 0): pinv cannot give the torque, vscmg gives it exactly."""
    short = ["model.gimbal_angles_deg=[0, 0, 0, 0]", "sim.duration_s=25", "checks={}"]
    result = testbed.run("reorient_near_singular_vscmg", overrides=short + ["pipeline.allocator.fault_detection=true"])
    m = result.metrics
    # the fault detection reads the rotors against their commanded speeds: no false alarm
    assert m["isolated_unit"] == 0 and np.nanmax(result.trace["allocator/fault_residual"][1]) < 0.5
    assert m["min_singularity_measure"] == 0.0  # the gimbal part starts exactly singular
    wanted, delivered = delivered_torque(result)
    assert relative_rms(delivered, wanted) <= 1e-6  # computed here from the commands and eq. (15): round-off, 1e-16 measured
    assert m["torque_error_rel"] <= 1e-6 and m["min_scale"] == 1.0
    _, speeds = result.trace["truth/rotor_rate"]
    rpm = speeds * 30 / np.pi
    assert rpm.min() >= 5100 and rpm.max() <= 6900  # the law's range
    assert rpm.max() - rpm.min() > 500  # the wheels did work
    assert m["momentum_drift_rel"] <= 1e-9  # only internal torques: RK4's error (2.8e-11 over 60 s)
    single = testbed.run("reorient_near_singular_vscmg", overrides=short + [
        "pipeline.allocator={type: pinv, beta_rate_max_deg_s: 30}"])
    assert single.metrics["torque_error_rel"] > 0.1


@pytest.mark.parametrize("override, field, words", [
    ("pipeline.allocator.rotor_speed_range_rpm=[4000, 6900]", "pipeline.allocator.rotor_speed_range_rpm",
     ("leaves the rotors' range",)),
    ("pipeline.allocator.rotor_speed_range_rpm=[6100, 6900]", "pipeline.allocator.rotor_speed_range_rpm",
     ("starts at 6000 rpm",)),
    ("pipeline.allocator.rotor_speed_range_rpm=[6900, 5100]", "pipeline.allocator.rotor_speed_range_rpm",
     ("must be below",)),
    ("model.rotor_speed_range_rpm=[6500, 7200]", "model.rotor_speed_range_rpm", ("must hold the nominal",)),
    ("model.rotor_speed_range_rpm=null", "pipeline.allocator.type", ("model.rotor_speed_range_rpm",)),
])
def test_a_speed_range_the_rotors_cannot_hold_is_refused(override, field, words, capfd, tmp_path):
    out = tmp_path / "never.rrd"
    code = main(["run", "reorient_near_singular_vscmg", "--set", override, "--set", "checks={}", "--out", str(out)])
    err = capfd.readouterr().err
    assert code == 2 and err.startswith(f"error: {field}: ") and all(w in err for w in words), err
    assert "Traceback" not in err and not out.exists()


def test_a_rotor_that_spins_down_leaves_its_speed_range_and_is_isolated():
    """spin_down on a variable-speed rotor: its motor is off, the speed range no longer holds it,
    W = W(t0) exp(-(t - t0) / tau) (tau = 2 s); the fault detection drops unit 3 at the 1 %
    threshold: 0.02 s of decay plus 3 ticks of persistence after the fault's tick."""
    result = testbed.run("reorient_near_singular_vscmg", overrides=[
        "model.faults=[{at_s: 10, unit: 3, kind: spin_down, time_constant_s: 2}]", "sim.duration_s=14",
        "checks={}", "pipeline.allocator.fault_detection=true"])
    t, speeds = result.trace["truth/rotor_rate"]
    start = np.searchsorted(t, 10.0)
    late = t >= 10.5
    expected = speeds[start, 2] * np.exp(-(t[late] - t[start]) / 2.0)
    assert np.max(np.abs(speeds[late, 2] / expected - 1.0)) <= 1e-3
    assert result.metrics["isolated_unit"] == 3
    assert 10.0 < result.metrics["isolation_time_s"] <= 10.25
