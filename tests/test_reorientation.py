"""Reorientation with CMG steering (issue 3, SEEDS §004): the scenarios, the attitude sensor
and slew law stages, the steering metrics, checked against independent numbers."""

from __future__ import annotations

import numpy as np
import pytest

from testbed.runner import stage_context
from testbed.math.quaternion import quat_angle, quat_conj, quat_from_axis_angle, quat_mul
from testbed.runner import run_scenario
from testbed.scenario.loading import load_scenario
from testbed.stages.attitude_sensor import IdealAttitude, IdealAttitudeParams
from testbed.guidance.slew import Slew, SlewParams
from testbed.steering import pinv_steering
from rhombus_reference import rhombus_jacobian

AXIS = np.ones(3) / np.sqrt(3.0)


@pytest.fixture(scope="module")
def runs():
    """The same 60 deg slew steered by min-max and by the pseudo-inverse (about 2-3 s each)."""
    return {law: run_scenario(load_scenario(f"reorient_{law}"), None, keep_data=True)
            for law in ("minimax", "pinv")}


@pytest.mark.slow
def test_both_laws_pass_their_checks_and_reach_the_target(runs):
    target = quat_from_axis_angle(AXIS, np.radians(60.0))  # q0 = identity, rotation about a body axis
    for result in runs.values():
        assert result.passed, result.checks
        final = result.data.recorder["truth/quat"][-1]
        angle = np.degrees(quat_angle(quat_mul(quat_conj(target), final)))
        assert angle < 1e-3
        assert result.metrics["final_attitude_error_deg"] == pytest.approx(angle, abs=1e-9)


@pytest.mark.slow
def test_minimax_peak_gimbal_rate_is_lower_than_pinv(runs):
    minimax, pinv = (runs[law].metrics["peak_gimbal_rate_deg_s"] for law in ("minimax", "pinv"))
    assert minimax < 0.8 * pinv
    # the servos follow: the measured peaks agree with the commands to 1 %
    for result in runs.values():
        m = result.metrics
        assert m["peak_gimbal_rate_measured_deg_s"] == pytest.approx(m["peak_gimbal_rate_deg_s"], rel=0.01)


@pytest.mark.slow
def test_minimax_command_never_exceeds_pinv_on_the_same_demand(runs):
    """Sample by sample, for the recorded gimbal angles and wanted H' the min-max peak rate is
    at most the minimum-norm (pseudo-inverse) one: min-max optimality, eq. (21)."""
    rec = runs["minimax"].data.recorder
    alpha, h = np.radians(54.7356), 25.0
    rates = rec["allocator/gimbal_rates"]
    torque, omega, H = rec["law/torque"], rec["truth/omega"], rec["truth/cmg_momentum"]
    for k in range(0, len(rec.time) - 1, 25):
        hdot = -(torque[k] + np.cross(omega[k], H[k]))
        J = rhombus_jacobian(rec["truth/gimbal_angle"][k], alpha)
        reference = pinv_steering(J, h, hdot, np.inf).beta_rate
        assert np.max(np.abs(rates[k])) <= np.max(np.abs(reference)) * (1 + 1e-9) + 1e-15
        np.testing.assert_allclose(h * J @ rates[k], hdot, atol=1e-9 * (1 + np.linalg.norm(hdot)))


@pytest.mark.slow
def test_singularity_measure_recorded_every_step_matches_eq18(runs):
    rec = runs["pinv"].data.recorder
    beta, measured = rec["truth/gimbal_angle"][:-1], rec["allocator/singularity"][:-1, 0]
    J = np.stack([rhombus_jacobian(b, np.radians(54.7356)) for b in beta])
    expected = np.sqrt(np.linalg.det(J @ J.transpose(0, 2, 1)))
    np.testing.assert_allclose(measured, expected, rtol=1e-9)
    assert runs["pinv"].metrics["min_singularity_measure"] == pytest.approx(expected.min(), rel=1e-9)


@pytest.mark.slow
def test_near_singular_slew_minimax_closes_in_pinv_keeps_away():
    """Both laws fly the slew within the rate limit to 0.05 deg; min-max passes within 1e-3 of a
    singular set (4.75e-5 at dt 0.002 to 0.01 s). Which side of it the pseudo-inverse passes is a
    knife-edge that the step decides (least measure 0.085 at dt 0.0025 and 0.005 s, 6e-6 at
    0.002 and 0.01 s): the comparison is made at 0.005 s, where it keeps away."""
    results = {law: run_scenario(load_scenario("reorient_near_singular", [f"pipeline.allocator.type={law}",
                                                                          "sim.dt_s=0.005"]),
                                 None, keep_data=True) for law in ("minimax", "pinv")}
    limit = 30.0
    for result in results.values():
        rates = result.data.recorder["allocator/gimbal_rates"][:-1]
        assert np.all(np.isfinite(rates))
        assert np.degrees(np.abs(rates).max()) <= limit * (1 + 1e-12)
        assert result.metrics["rate_limit_violations"] == 0
        assert result.metrics["final_attitude_error_deg"] < 0.05
    assert results["minimax"].passed
    assert results["minimax"].metrics["min_singularity_measure"] < 1e-3
    assert results["pinv"].metrics["min_singularity_measure"] > 0.05
    # the min-max law paid for the near-singular pass with a scaled demand
    assert results["minimax"].metrics["min_scale"] < 1.0


@pytest.mark.slow
def test_singularity_avoiding_minimax_keeps_away_with_exact_torque_near_singular():
    """Issue 14's figures on reorient_near_singular's slew: min sqrt(det JJ') >= 0.05, torque error
    <= 1e-3, final error <= 0.01 deg, peak rate within 10 % of minimax_lp's on the same slew."""
    avoid = run_scenario(load_scenario("reorient_near_singular_avoid"), None, keep_data=True)
    lp = run_scenario(load_scenario("reorient_near_singular", ["pipeline.allocator.type=minimax_lp"]), None)
    assert avoid.passed, avoid.checks
    m = avoid.metrics
    assert m["min_singularity_measure"] >= 0.05 and m["torque_error_rel"] <= 1e-3
    assert m["final_attitude_error_deg"] <= 0.01
    assert abs(m["peak_gimbal_rate_deg_s"] / lp.metrics["peak_gimbal_rate_deg_s"] - 1) <= 0.10
    assert lp.metrics["min_singularity_measure"] < 1e-3  # the plain LP law goes singular here
    # the barrier did act (status bit 8, avoidance_limited) and never cost torque (bit 1 never set)
    status = avoid.data.recorder["allocator/status"][:-1, 0].astype(int)
    assert np.any(status & 8) and not np.any(status & 1)
    rec = avoid.data.recorder  # the torque equation h J beta' = H' holds sample by sample
    np.testing.assert_allclose(rec["allocator/torque_delivered"][:-1], rec["law/torque"][:-1], atol=1e-9)


@pytest.mark.slow
def test_singularity_avoiding_minimax_is_min_max_far_from_singular_sets(runs):
    """On reorient_minimax's slew the barrier never acts and the pull back to the start spends only
    rate below the peak the demand set on the slew's first step: the peak rate is minimax's (to
    rounding; the issue asks for 2 %), the torque exact sample by sample. The commands themselves
    differ from minimax's once the pull has moved the gimbals (module doc, eq. 4-5)."""
    avoid = run_scenario(load_scenario("reorient_minimax_avoid"), None, keep_data=True)
    assert avoid.passed, avoid.checks
    plain = runs["minimax"]
    assert abs(avoid.metrics["peak_gimbal_rate_deg_s"] / plain.metrics["peak_gimbal_rate_deg_s"] - 1) <= 1e-9
    rec = avoid.data.recorder
    np.testing.assert_allclose(rec["allocator/torque_delivered"][:-1], rec["law/torque"][:-1], atol=1e-9)
    assert not np.any(rec["allocator/status"][:-1, 0])


# --- the stages on their own ---------------------------------------------------------------

class _Plant:
    def __init__(self, quat, omega):
        self._q, self._w = np.asarray(quat, float), np.asarray(omega, float)

    def quat(self):
        return self._q

    def omega(self):
        return self._w


def test_ideal_attitude_noise_has_the_stated_spread_and_repeats_with_the_seed():
    q = quat_from_axis_angle(AXIS, 0.7)
    plant = _Plant(q, [0.01, -0.02, 0.03])
    params = IdealAttitudeParams(attitude_noise_rad=1e-4, rate_noise_rad_s=1e-5, seed=7)
    a, b = IdealAttitude(params, None), IdealAttitude(params, None)
    samples = [a.measure(0.0, plant) for _ in range(4000)]
    assert all(np.array_equal(s["quat"], b.measure(0.0, plant)["quat"]) for s in samples[:50])
    angles = np.array([quat_angle(quat_mul(quat_conj(q), s["quat"])) for s in samples])
    # |δθ| of a 3-D isotropic Gaussian: E|δθ|² = 3 σ²
    assert np.sqrt(np.mean(angles**2)) == pytest.approx(np.sqrt(3) * 1e-4, rel=0.05)
    rate_err = np.array([s["omega"] for s in samples]) - plant.omega()
    assert rate_err.std(axis=0) == pytest.approx([1e-5] * 3, rel=0.05)
    exact = IdealAttitude(IdealAttitudeParams(), None).measure(0.0, plant)
    assert np.array_equal(exact["quat"], q) and np.array_equal(exact["omega"], plant.omega())


def _slew(**kw):
    scenario = load_scenario("reorient_minimax")
    inertia = np.array([[900.0, 20.0, -10.0], [20.0, 1000.0, 5.0], [-10.0, 5.0, 1200.0]])
    ctx = stage_context(scenario, inertia)
    params = SlewParams(axis=list(AXIS), angle_deg=60.0, duration_s=40.0, start_s=5.0, **kw)
    return Slew(params, ctx), inertia


def test_slew_on_the_program_asks_for_the_program_torque_eq9():
    law, inertia = _slew()
    t, step = 20.0, 1e-4
    q_p, w_p, _ = law.program.state(t - 5.0)
    out = law.torque(t, {"quat": q_p, "omega": w_p})
    # M* = I w*' + w* x I w*, with w*' by a central difference of eq. (7)
    dw = (law.program.rate(t - 5.0 + step) - law.program.rate(t - 5.0 - step)) / (2 * step)
    np.testing.assert_allclose(out["torque"], inertia @ dw + np.cross(w_p, inertia @ w_p), atol=1e-6)
    assert out["error_angle"][0] == pytest.approx(0.0, abs=1e-12)
    # at the end the program is at q0 ∘ (axis, 60 deg) and at rest
    q_end, w_end, _ = law.program.state(40.0)
    assert quat_angle(quat_mul(quat_conj(quat_from_axis_angle(AXIS, np.radians(60))), q_end)) < 1e-9
    np.testing.assert_allclose(w_end, 0.0, atol=1e-12)


def test_slew_records_a_known_attitude_error():
    law, _ = _slew()
    q_p, w_p, _ = law.program.state(10.0)
    tilted = quat_mul(q_p, quat_from_axis_angle([0.0, 1.0, 0.0], 0.01))  # 0.01 rad about body y
    out = law.torque(15.0, {"quat": tilted, "omega": w_p})
    np.testing.assert_allclose(out["attitude_error"], [0.0, 0.01, 0.0], atol=1e-12)
    np.testing.assert_allclose(out["program_quat"], q_p, atol=1e-15)


def test_slew_with_boundary_rates_meets_them():
    w0, wT = [0.5, -0.2, 0.1], [0.0, 0.3, 0.2]
    law, _ = _slew(initial_rate_deg_s=w0, final_rate_deg_s=wT)
    np.testing.assert_allclose(law.program.state(0.0)[1], np.radians(w0), atol=1e-12)
    np.testing.assert_allclose(law.program.state(40.0)[1], np.radians(wT), atol=1e-12)


def test_a_run_that_ends_before_its_slew_does_fails_its_attitude_check(tmp_path, capsys):
    """reorient_minimax cut at 20 s, 15 s into its 40 s slew: the body is far from the target
    q0 ∘ (axis, 60 deg) (it passed before, measured against the program at 20 s); the error is
    the angle from the recorded final attitude to that target, and the program is still tracked."""
    from testbed.cli import main

    result = run_scenario(load_scenario("reorient_minimax", ["sim.duration_s=20"]), None, keep_data=True)
    target = quat_from_axis_angle(AXIS, np.radians(60.0))
    final = result.data.recorder["truth/quat"][-1]
    angle = np.degrees(quat_angle(quat_mul(quat_conj(target), final)))
    assert angle > 30.0
    assert result.metrics["final_attitude_error_deg"] == pytest.approx(angle, rel=1e-9)
    assert result.metrics["final_tracking_error_deg"] < 0.05
    assert not result.passed and [c["name"] for c in result.checks if not c["passed"]] == ["final_attitude_error_deg"]
    assert main(["run", "reorient_minimax", "--set", "sim.duration_s=20", "--out", str(tmp_path / "x.rrd")]) == 1


def test_the_slew_target_past_the_end_spins_on_at_the_final_rate():
    """The target the metric measures against, from the scenario's numbers, equals the program
    (a second construction, SEEDS §004 eq. 5-13) at rest before the slew ends and, past its end,
    q0 ∘ (axis, angle) turned at the final body rate: q(t) = qT ∘ (w/|w|, |w| (t - start - T))."""
    from testbed.guidance.slew import slew_target

    wT = [0.0, 0.3, 0.2]
    law, _ = _slew(final_rate_deg_s=wT)
    params = SlewParams(axis=list(AXIS), angle_deg=60.0, duration_s=40.0, start_s=5.0, final_rate_deg_s=wT)
    q0 = law.program.attitude(0.0)
    qT = quat_from_axis_angle(AXIS, np.radians(60.0))
    assert quat_angle(quat_mul(quat_conj(slew_target(params, [1, 0, 0, 0], 30.0)), qT)) == 0.0
    for after in (0.0, 7.0, 60.0):
        rate = np.radians(wT)
        expected = quat_mul(qT, quat_from_axis_angle(rate / np.linalg.norm(rate), np.linalg.norm(rate) * after))
        got = slew_target(params, [1, 0, 0, 0], 45.0 + after)
        assert quat_angle(quat_mul(quat_conj(expected), got)) < 1e-12
        assert quat_angle(quat_mul(quat_conj(law.program.attitude(40.0 + after)), got)) < 1e-9
    assert quat_angle(quat_mul(quat_conj(q0), [1.0, 0, 0, 0])) < 1e-12


@pytest.mark.slow
def test_steering_extremes_count_every_control_step_whatever_the_trace_period(runs):
    """A trace 20x coarser than the control period changes nothing in the dynamics, so the
    steering extremes (taken by the allocator at every step) must equal those of the full trace."""
    coarse = run_scenario(load_scenario("reorient_pinv", ["sim.trace_period_s=1.0"]), None, keep_data=True)
    full = runs["pinv"]
    assert len(coarse.data.recorder.time) < len(full.data.recorder.time) / 10
    for name in ("peak_gimbal_rate_deg_s", "min_singularity_measure", "min_scale", "rate_limit_violations"):
        assert coarse.metrics[name] == full.metrics[name], name
    rec = full.data.recorder  # full trace = every control step: the recorded extremes agree
    assert full.metrics["min_singularity_measure"] == np.nanmin(rec["allocator/singularity"])
    assert full.metrics["peak_gimbal_rate_deg_s"] == pytest.approx(
        np.degrees(np.nanmax(np.abs(rec["allocator/gimbal_rates"]))), rel=1e-15)
    assert full.data.statistics["allocator"]["steps"] == round(60.0 / 0.05)
