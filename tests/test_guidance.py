"""Program trajectory (SEEDS §004 eq. 5-13) and the tracking law, against independent numbers:
finite differences of Λ*, the closed forms of eq. (12), solve_ivp integration of the rigid body."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from testbed.errors import InputError
from testbed.guidance.program_trajectory import ProgramTrajectory
from testbed.guidance.tracking_law import TrackingLaw
from testbed.math.quaternion import quat_angle, quat_conj, quat_from_axis_angle, quat_mul, quat_rotate

# A non-diagonal inertia so products of inertia and gyroscopic coupling are exercised [kg m²].
INERTIA = np.array([[120.0, 5.0, -3.0], [5.0, 90.0, 4.0], [-3.0, 4.0, 60.0]])
T = 60.0


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


Q0 = quat_from_axis_angle(_unit([0.3, -0.5, 0.8]), 0.4)
QT = quat_mul(Q0, quat_from_axis_angle(_unit([1.0, 2.0, -0.5]), 2.6))  # a 149° slew
CASES = {
    "rest_to_rest": (np.zeros(3), np.zeros(3)),
    "moving_start_and_end": (np.array([0.01, -0.02, 0.015]), np.array([-0.005, 0.02, 0.01])),
    "moving_start": (np.array([0.0, 0.03, -0.01]), np.zeros(3)),
    "moving_end": (np.zeros(3), np.array([0.02, 0.0, -0.02])),
}


def _program(case):
    w0, wT = CASES[case]
    return ProgramTrajectory.from_boundary(Q0, w0, QT, wT, T)


def _attitude_error(q, q_ref):
    return quat_angle(quat_mul(quat_conj(q_ref), q))


def _rigid_body_rhs(torque):
    """Λ' = Λ∘ω/2 (eq. 1), I ω' = M - ω × I ω (eq. 2), state (q, ω)."""
    inv = np.linalg.inv(INERTIA)

    def rhs(t, x):
        q, w = x[:4], x[4:]
        dq = 0.5 * quat_mul(q, np.concatenate([[0.0], w]))
        dw = inv @ (torque(t, q, w) - np.cross(w, INERTIA @ w))
        return np.concatenate([dq, dw])

    return rhs


@pytest.mark.parametrize("case", CASES)
def test_boundary_attitude_and_rates_are_met(case):
    w0, wT = CASES[case]
    p = _program(case)
    assert _attitude_error(p.attitude(0.0), Q0) < 1e-9
    assert _attitude_error(p.attitude(T), QT) < 1e-9
    np.testing.assert_allclose(p.rate(0.0), w0, atol=1e-9)
    np.testing.assert_allclose(p.rate(T), wT, atol=1e-9)


@pytest.mark.parametrize("case", CASES)
def test_boundary_values_match_closed_forms_of_eq12(case):
    """ψ0, ψ0' from the half-angle and projection formulas of eq. (12) (right-handed b1 = b2 × b3)."""
    w0, wT = CASES[case]
    p = _program(case)
    b1, b2, b3 = p.axes
    lam = quat_mul(quat_conj(QT), Q0)
    lam = lam if lam[0] >= 0 else -lam
    psi0, dpsi0, _ = p.angles(0.0)
    psi1, psi2, psi3 = psi0
    assert psi1 == 0.0
    # ψ30 = 2 arctg((λ, b3)/λ0); ψ20 = 2 arcsin(λ, b2'') with b2'' = sin(ψ30/2) b1 + cos(ψ30/2) b2
    # (both up to the sign of Λ, i.e. ψ3 modulo 2π).
    assert np.isclose(np.cos(psi3 / 2) ** 2, np.cos(2 * np.arctan(lam[1:] @ b3 / lam[0]) / 2) ** 2)
    b2pp = np.sin(psi3 / 2) * b1 + np.cos(psi3 / 2) * b2
    assert abs(abs(np.sin(psi2 / 2)) - abs(lam[1:] @ b2pp)) < 1e-12
    # ψ10' = (ω0, b1')/cos ψ20, ψ20' = (ω0, b2'), ψ30' = (ω0, b3) - sin ψ20 ψ10'.
    d1 = w0 @ (np.cos(psi3) * b1 - np.sin(psi3) * b2) / np.cos(psi2)
    d2 = w0 @ (np.sin(psi3) * b1 + np.cos(psi3) * b2)
    d3 = w0 @ b3 - np.sin(psi2) * d1
    np.testing.assert_allclose(dpsi0, [d1, d2, d3], atol=1e-13)
    # End: all ψ = 0 and ψT' = (0, 0, |ωT|) because b3 = ωT/|ωT| (eq. 10).
    psiT, dpsiT, _ = p.angles(T)
    np.testing.assert_allclose(psiT, 0.0, atol=1e-12)
    np.testing.assert_allclose(dpsiT, [0.0, 0.0, np.linalg.norm(wT)], atol=1e-13)
    if np.any(wT):
        np.testing.assert_allclose(b3, wT / np.linalg.norm(wT), atol=1e-15)


@pytest.mark.parametrize("case", ["rest_to_rest", "moving_start_and_end"])
def test_rate_and_acceleration_match_finite_differences(case):
    p = _program(case)
    h = 1e-3
    for t in (3.0, 17.5, 30.0, 51.2):
        lam = p.attitude(t)
        dlam = (p.attitude(t + h) - p.attitude(t - h)) / (2 * h)
        w_fd = 2.0 * quat_mul(quat_conj(lam), dlam)[1:]  # eq. (7) with a numerical Λ*'
        np.testing.assert_allclose(p.rate(t), w_fd, atol=1e-9)
        dw_fd = (p.rate(t + h) - p.rate(t - h)) / (2 * h)
        np.testing.assert_allclose(p.acceleration(t), dw_fd, atol=1e-9)
        ddlam = (p.attitude(t + h) - 2 * lam + p.attitude(t - h)) / h**2
        dw_eq8 = 2.0 * (quat_mul(quat_conj(dlam), dlam) + quat_mul(quat_conj(lam), ddlam))[1:]
        np.testing.assert_allclose(p.acceleration(t), dw_eq8, atol=1e-7)


@pytest.mark.parametrize("case", ["rest_to_rest", "moving_start_and_end"])
def test_program_torque_open_loop_lands_on_target(case):
    w0, wT = CASES[case]
    p = _program(case)
    rhs = _rigid_body_rhs(lambda t, q, w: p.torque(t, INERTIA))
    sol = solve_ivp(rhs, (0.0, T), np.concatenate([Q0, w0]), method="DOP853", rtol=1e-12, atol=1e-12)
    assert sol.success
    q_end, w_end = sol.y[:4, -1], sol.y[4:, -1]
    assert _attitude_error(q_end / np.linalg.norm(q_end), QT) < 1e-8
    np.testing.assert_allclose(w_end, wT, atol=1e-10)


def test_rest_to_rest_is_an_eigen_axis_slew_with_cubic_profile():
    axis, angle = _unit([0.2, -0.7, 0.4]), 2.0
    p = ProgramTrajectory.eigen_axis_slew(Q0, axis, angle, T)
    for t in np.linspace(0.0, T, 7):
        w = p.rate(t)
        assert np.linalg.norm(np.cross(w, axis)) < 1e-15
        # Cubic with zero end rates: angle θ(t) = θ (3 s² - 2 s³), s = t/T (eq. 13).
        s = t / T
        expected = angle * (3 * s**2 - 2 * s**3)
        q_expected = quat_mul(Q0, quat_from_axis_angle(axis, expected))
        assert _attitude_error(p.attitude(t), q_expected) < 1e-12
        np.testing.assert_allclose(w @ axis, angle * (6 * s - 6 * s**2) / T, atol=1e-15)
    # The peak rate of the cubic is 1.5 θ/T, at mid-slew.
    assert np.isclose(np.linalg.norm(p.rate(T / 2)), 1.5 * angle / T, rtol=1e-12)


def test_after_the_slew_the_program_spins_steadily_at_the_end_rate():
    p = _program("moving_end")
    wT = CASES["moving_end"][1]
    for t in (T + 1.0, T + 20.0):
        np.testing.assert_allclose(p.rate(t), wT, atol=1e-15)
        np.testing.assert_allclose(p.acceleration(t), 0.0, atol=1e-15)
        np.testing.assert_allclose(p.torque(t, INERTIA), np.cross(wT, INERTIA @ wT), atol=1e-13)
    # Constant body rate about a fixed body axis: the attitude is ΛT ∘ exp(ωT (t - T) / 2).
    dt = 20.0
    q_expected = quat_mul(QT, quat_from_axis_angle(_unit(wT), np.linalg.norm(wT) * dt))
    assert _attitude_error(p.attitude(T + dt), q_expected) < 1e-12


def test_bad_input_is_reported_by_field():
    with pytest.raises(InputError) as e:
        ProgramTrajectory.from_boundary(Q0, np.zeros(3), QT, np.zeros(3), 0.0)
    assert e.value.field == "slew.duration_s"
    with pytest.raises(InputError) as e:
        ProgramTrajectory.from_boundary(Q0, np.zeros(3), QT, np.zeros(3), -5.0)
    assert e.value.field == "slew.duration_s"
    with pytest.raises(InputError) as e:
        ProgramTrajectory.eigen_axis_slew(Q0, [0.0, 0.0, 0.0], 1.0, T)
    assert e.value.field == "slew.axis"
    with pytest.raises(InputError) as e:
        ProgramTrajectory.eigen_axis_slew(Q0, [0.0, 0.0, 2.0], 1.0, T)
    assert e.value.field == "slew.axis"
    with pytest.raises(InputError) as e:
        ProgramTrajectory.from_boundary(2 * Q0, np.zeros(3), QT, np.zeros(3), T)
    assert e.value.field == "slew.q_initial"
    with pytest.raises(InputError) as e:
        ProgramTrajectory.from_boundary(Q0, [0.0, np.nan, 0.0], QT, np.zeros(3), T)
    assert e.value.field == "slew.w_initial_rad_s"
    with pytest.raises(InputError) as e:
        ProgramTrajectory(QT, 2 * np.eye(3), np.zeros((3, 4)), T)
    assert e.value.field == "slew.axes"
    with pytest.raises(InputError) as e:
        ProgramTrajectory.eigen_axis_slew(Q0, [1.0, 0.0, 0.0], 1.0, T).torque(1.0, [1.0, -2.0, 3.0])
    assert e.value.field == "body.inertia"
    # The final rate axis z turned by 90° (start = 90° about x): ψ20 = 90°, the model's
    # Cardan singularity, where a non-zero initial rate cannot be represented.
    q90 = quat_from_axis_angle(np.array([1.0, 0.0, 0.0]), np.pi / 2)
    with pytest.raises(InputError) as e:
        ProgramTrajectory.from_boundary(q90, [0.01, 0.0, 0.0], [1, 0, 0, 0], [0.0, 0.0, 0.01], T)
    assert e.value.field == "slew.w_initial_rad_s"


# ---- tracking law --------------------------------------------------------------------------


def test_on_the_program_the_feedback_vanishes_and_the_law_is_the_program_torque():
    p = _program("moving_start_and_end")
    law = TrackingLaw(p, INERTIA, natural_frequency=0.3, damping_ratio=0.7)
    for t in (0.0, 12.0, 45.0, T):
        q, w = p.attitude(t), p.rate(t)
        np.testing.assert_allclose(law.feedback(t, q, w), 0.0, atol=1e-12)
        np.testing.assert_allclose(law(t, q, w), p.torque(t, INERTIA), atol=1e-12)
        np.testing.assert_allclose(law(t, -q, w), p.torque(t, INERTIA), atol=1e-12)  # -q: same attitude


def _error_angle_along(law, t, q, w, axis):
    dq, _, _ = law.errors(t, q, w)
    dq = dq if dq[0] >= 0 else -dq
    return 2.0 * np.arctan2(dq[1:] @ axis, dq[0])


def test_single_axis_offset_decays_like_the_exact_scalar_error_equation():
    """With Kp = 2ωn² I, Kd = 2ζωn I the error obeys δω' = -2ωn² vec(δq) - 2ζωn δω exactly;
    an offset about one axis n stays on n, so θ'' = -2ωn² sin(θ/2) - 2ζωn θ'."""
    wn, zeta = 0.3, 0.7
    p = _program("moving_start_and_end")
    law = TrackingLaw(p, INERTIA, wn, zeta)
    n = _unit([1.0, -1.0, 2.0])
    theta0, dtheta0 = 0.5, -0.02
    dq0 = quat_from_axis_angle(n, theta0)
    q0 = quat_mul(p.attitude(0.0), dq0)
    w0 = quat_rotate(quat_conj(dq0), p.rate(0.0)) + dtheta0 * n
    t_eval = np.linspace(0.0, T, 13)
    rhs = _rigid_body_rhs(law)
    sol = solve_ivp(rhs, (0.0, T), np.concatenate([q0, w0]), method="DOP853", t_eval=t_eval,
                    rtol=1e-11, atol=1e-12)
    assert sol.success
    scalar = solve_ivp(lambda t, x: [x[1], -2 * wn**2 * np.sin(x[0] / 2) - 2 * zeta * wn * x[1]],
                       (0.0, T), [theta0, dtheta0], method="DOP853", t_eval=t_eval, rtol=1e-12, atol=1e-14)
    for k, t in enumerate(t_eval):
        q = sol.y[:4, k] / np.linalg.norm(sol.y[:4, k])
        theta = _error_angle_along(law, t, q, sol.y[4:, k], n)
        assert abs(theta - scalar.y[0, k]) < 1e-9
    dq_end, dw_end, _ = law.errors(T, sol.y[:4, -1] / np.linalg.norm(sol.y[:4, -1]), sol.y[4:, -1])
    assert quat_angle(dq_end) < 1e-5 and np.linalg.norm(dw_end) < 1e-6


def test_general_offset_converges_onto_the_program():
    p = _program("rest_to_rest")
    law = TrackingLaw(p, INERTIA, natural_frequency=0.4, damping_ratio=0.9)
    # A large attitude error (2.5 rad: sign(δq_w) must pick the short way) and an unrelated rate error.
    q0 = quat_mul(Q0, quat_from_axis_angle(_unit([0.0, 1.0, 1.0]), 2.5))
    w0 = np.array([0.05, -0.03, 0.02])
    t_eval = np.linspace(0.0, T, 31)
    sol = solve_ivp(_rigid_body_rhs(law), (0.0, T), np.concatenate([q0, w0]), method="DOP853",
                    t_eval=t_eval, rtol=1e-10, atol=1e-12)
    assert sol.success
    angles = []
    for k, t in enumerate(t_eval):
        q = sol.y[:4, k] / np.linalg.norm(sol.y[:4, k])
        angles.append(quat_angle(law.errors(t, q, sol.y[4:, k])[0]))
    angles = np.array(angles)
    assert angles[0] > 2.4
    assert angles[-1] < 1e-6
    # The decay is oscillatory per axis (ζ < 1), so compare quarter-by-quarter maxima:
    # each quarter (15 s, e^(-ζ ωn 15 s) ≈ 0.004) is at least 10x smaller than the one before.
    quarter_max = [angles[k : k + 8].max() for k in (0, 8, 16, 23)]
    assert all(b < 0.1 * a for a, b in zip(quarter_max, quarter_max[1:]))


def test_tracking_law_rejects_bad_gains():
    p = _program("rest_to_rest")
    with pytest.raises(InputError) as e:
        TrackingLaw(p, INERTIA, natural_frequency=0.0, damping_ratio=0.7)
    assert e.value.field == "control.natural_frequency_rad_s"
    with pytest.raises(InputError) as e:
        TrackingLaw(p, INERTIA, natural_frequency=0.3, damping_ratio=-1.0)
    assert e.value.field == "control.damping_ratio"
    with pytest.raises(InputError) as e:
        TrackingLaw(p, INERTIA, 0.3, 0.7)(1.0, [1.0, 0.0, 0.0, 0.5], np.zeros(3))
    assert e.value.field == "state.q"
