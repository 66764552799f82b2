"""Avdeev & Kaptsova 2016: analytic LQR for planar attitude, checked against scipy and simulation."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import solve_continuous_are

from testbed.systems.planar.akor_regulator import (
    closed_loop_matrix,
    complex_roots,
    control,
    error_coefficients,
    error_coefficients_as_printed,
    error_coefficients_closed_form,
    eta_complex,
    eta_max,
    eta_real,
    beta22_double_root,
    lqr_gain,
    peak_power,
    power,
    power_closed_form,
    printed_formula_check,
    response,
    riccati_closed_form,
    roots_are_real,
    settling_time_95,
    settling_time_estimate,
    stability_margin,
    static_angle_error,
    steady_state,
)
from testbed.errors import InputError

# (b11, b22, k) spanning complex roots, the double root, and real roots far apart.
GRID = [(b11, b22, k) for b11 in (1e-3, 0.5, 4.0) for k in (0.01, 1.0, 50.0)
        for b22 in (0.0, 0.3 * 2 * np.sqrt(b11 / k), 2 * np.sqrt(b11 / k), 3.0 * 2 * np.sqrt(b11 / k), 40.0)]


def _sim(b11, b22, k, x0, t_end, m=lambda t: 0.0, t_eval=None):
    """Independent simulation of x' = a x + b u + c m with u from eq. 6 (solve_ivp)."""
    g = lqr_gain(b11, b22, k)

    def rhs(t, x):
        return [x[1], -g @ x + m(t)]

    return solve_ivp(rhs, (0.0, t_end), x0, method="DOP853", rtol=1e-11, atol=1e-13, t_eval=t_eval)


def test_riccati_closed_form_matches_scipy_on_grid():
    a = np.array([[0.0, 1.0], [0.0, 0.0]])
    b = np.array([[0.0], [1.0]])
    assert any(roots_are_real(*p) for p in GRID) and any(not roots_are_real(*p) for p in GRID)
    for b11, b22, k in GRID:
        ref = solve_continuous_are(a, b, np.diag([b11, b22]), np.array([[1.0 / k]]))
        S = riccati_closed_form(b11, b22, k)
        assert S == pytest.approx(ref, rel=1e-10, abs=1e-10 * np.max(np.abs(ref)))
        assert lqr_gain(b11, b22, k) == pytest.approx(k * ref[1], rel=1e-10)


def test_control_law_and_closed_loop_matrix():
    b11, b22, k = 0.5, 0.2, 3.0
    S = riccati_closed_form(b11, b22, k)
    x = np.array([0.1, -0.02])
    assert control(b11, b22, k, x) == pytest.approx(-k * (S[0, 1] * x[0] + S[1, 1] * x[1]))
    ast = closed_loop_matrix(b11, b22, k)
    g = lqr_gain(b11, b22, k)
    assert ast == pytest.approx(np.array([[0, 1], [0, 0]]) - np.outer([0, 1], g), rel=1e-10)


def test_root_classification_and_margins_from_eigenvalues():
    for b11, b22, k in GRID:
        ev = np.linalg.eigvals(closed_loop_matrix(b11, b22, k))
        eta = -np.max(ev.real)
        disc = b22 * np.sqrt(k) - 2 * np.sqrt(b11)
        if abs(disc) > 1e-9:
            assert roots_are_real(b11, b22, k) == bool(np.all(np.abs(ev.imag) < 1e-12))
        if roots_are_real(b11, b22, k):
            assert eta_real(b11, b22, k) == pytest.approx(eta, rel=1e-7)
        else:
            # At the double root eig() splits the pair by ~sqrt(eps); eq. 13 is exact.
            assert eta_complex(b11, b22, k) == pytest.approx(eta, rel=1e-6)
        assert stability_margin(b11, b22, k) == pytest.approx(eta, rel=1e-6)
    with pytest.raises(InputError):
        eta_real(1.0, 0.0, 1.0)


def test_double_root_gives_the_largest_margin():
    for b11, k in ((0.5, 2.0), (4.0, 0.01)):
        b22s = np.linspace(0.0, 5 * beta22_double_root(b11, k), 201)
        etas = [stability_margin(b11, b, k) for b in b22s]
        assert max(etas) == pytest.approx(eta_max(b11, k), rel=1e-3)
        assert stability_margin(b11, beta22_double_root(b11, k), k) == pytest.approx(eta_max(b11, k), rel=1e-12)
        er0, _ = error_coefficients(b11, beta22_double_root(b11, k), k)
        assert eta_max(b11, k) == pytest.approx(np.sqrt(1.0 / er0[0]), rel=1e-12)  # eq. 17


def test_error_coefficients_closed_form_and_printed_eq16():
    for b11, b22, k in GRID:
        er0, er1 = error_coefficients(b11, b22, k)
        c0, c1 = error_coefficients_closed_form(b11, b22, k)
        assert c0 == pytest.approx(er0, rel=1e-10, abs=1e-300)
        assert c1 == pytest.approx(er1, rel=1e-10)
        assert er1[0] < 0  # the angle settles behind a growing disturbance
        p0, p1 = error_coefficients_as_printed(b11, b22, k)
        assert p0 == pytest.approx(er0, rel=1e-10, abs=1e-300)
        assert p1 == pytest.approx([-er1[0], er1[1]], rel=1e-10)
        check = printed_formula_check(b11, b22, k)
        assert check["eq16.ER0"] and check["eq16.ER1[0].magnitude"] and check["eq16.ER1[1]"]
        assert not check["eq16.ER1[0].sign"]


def test_ramp_disturbance_steady_state_by_simulation():
    for b11, b22, k in ((0.5, 0.0, 2.0), (1.0, 2.0, 1.0), (0.2, 5.0, 3.0)):
        m0, m0dot = 2e-4, 3e-6
        t_end = 40.0 / stability_margin(b11, b22, k)
        sol = _sim(b11, b22, k, [0.01, 0.0], t_end, m=lambda t: m0 + m0dot * t, t_eval=[t_end])
        x_end = sol.y[:, -1]
        er0, er1 = error_coefficients(b11, b22, k)
        assert x_end == pytest.approx(m0dot * (er0 * t_end + er1) + er0 * m0, rel=1e-7, abs=1e-12)
        assert x_end == pytest.approx(steady_state(b11, b22, k, m0, m0dot, t_end), rel=1e-7, abs=1e-12)
        # Constant disturbance alone: static angle error m0 / sqrt(k b11).
        sol = _sim(b11, b22, k, [0.0, 0.0], t_end, m=lambda t: m0, t_eval=[t_end])
        assert sol.y[0, -1] == pytest.approx(static_angle_error(b11, k, m0), rel=1e-7)


def test_exact_response_matches_simulation():
    b11, b22, k = 0.7, 0.4, 1.5
    t = np.linspace(0.0, 12.0, 7)
    sol = _sim(b11, b22, k, [0.02, -0.01], 12.0, m=lambda s: 1e-3 + 1e-4 * s, t_eval=t)
    assert response(b11, b22, k, [0.02, -0.01], t, 1e-3, 1e-4) == pytest.approx(sol.y.T, rel=1e-8, abs=1e-12)


def test_settling_time_against_rule_of_thumb():
    # Tp by simulation: last exit of the angle from the 5 % band after a step disturbance.
    for b11, b22, k in ((1.0, 0.0, 1.0), (1.0, 1.0, 1.0), (1.0, 2.0, 1.0), (0.3, 6.0, 2.0)):
        eta = stability_margin(b11, b22, k)
        t = np.linspace(0.0, 20.0 / eta, 40001)
        x1 = _sim(b11, b22, k, [0.0, 0.0], t[-1], m=lambda s: 1.0, t_eval=t).y[0]
        final = static_angle_error(b11, k, 1.0)
        tp_sim = t[np.nonzero(np.abs(x1 - final) > 0.05 * final)[0].max() + 1]
        assert settling_time_95(b11, b22, k) == pytest.approx(tp_sim, abs=2 * (t[1] - t[0]))
    # Paper: Tp = 3/eta errs by -35 ... +35 %. Measured over the complex range:
    # (3/eta - Tp)/Tp = +44.8 % at b22 = 0 (damping 1/sqrt 2), -36.8 % at the double root.
    rel = lambda b22: settling_time_estimate(stability_margin(1.0, b22, 1.0)) / settling_time_95(1.0, b22, 1.0) - 1
    assert rel(0.0) == pytest.approx(0.448, abs=0.001)
    assert rel(2.0) == pytest.approx(-0.368, abs=0.001)
    for b22 in (0.2, 0.5, 1.0, 1.5, 1.9, 2.5, 4.0, 10.0, 100.0):  # within the paper's band here
        assert abs(rel(b22)) < 0.35
    # With the brief's reading |Tp - 3/eta| <= 0.35 * 3/eta the fit holds from b22 = 0 to ~1.2.
    for b22 in (0.0, 0.5, 1.0):
        tp, est = settling_time_95(1.0, b22, 1.0), 3 / stability_margin(1.0, b22, 1.0)
        assert abs(tp - est) <= 0.35 * est


def _sim_peak_power(b11, b22, k, x10, t_end):
    """Peak of eq. 18 along a solve_ivp path: coarse grid, then a fine grid around the max."""
    t = np.linspace(0.0, t_end, 2001)
    P = power(b11, b22, k, _sim(b11, b22, k, [x10, 0.0], t_end, t_eval=t).y.T)
    i = int(np.argmax(P))
    tf = np.linspace(t[max(i - 1, 0)], t[i + 1], 2001)
    Pf = power(b11, b22, k, _sim(b11, b22, k, [x10, 0.0], tf[-1], t_eval=tf).y.T)
    return tf[np.argmax(Pf)], Pf.max(), t, P


def test_power_and_its_peak():
    x10 = 0.05
    for b11, b22, k in ((1.0, 0.0, 1.0), (2.0, 0.3, 4.0), (1.0, 1.0, 1.0)):
        assert not roots_are_real(b11, b22, k)
        t_sim, p_sim, t, P_sim = _sim_peak_power(b11, b22, k, x10, 10.0)
        # eq. 18 along the simulated path equals eq. 20 (with the corrected beta).
        assert power_closed_form(b11, b22, k, x10, t) == pytest.approx(P_sim, rel=1e-6, abs=1e-12 * x10**2)
        sol = _sim(b11, b22, k, [x10, 0.0], 1.0, t_eval=[0.3, 1.0])
        u = np.array([control(b11, b22, k, x) for x in sol.y.T])
        assert power(b11, b22, k, sol.y.T) == pytest.approx(u * sol.y[1], rel=1e-12)
        tp, pp = peak_power(b11, b22, k, x10)
        assert pp == pytest.approx(p_sim, rel=1e-8)
        assert tp == pytest.approx(t_sim, abs=1e-4)
        al, be = complex_roots(b11, b22, k)
        assert al**2 + be**2 == pytest.approx(k * riccati_closed_form(b11, b22, k)[0, 1], rel=1e-12)
    # Real / double roots: the numeric peak agrees with a dense simulation too.
    for b11, b22, k in ((1.0, 2.0, 1.0), (1.0, 50.0, 1.0)):
        fast = np.max(np.abs(np.linalg.eigvals(closed_loop_matrix(b11, b22, k))))
        t_sim, p_sim, _, _ = _sim_peak_power(b11, b22, k, x10, 5.0 / fast)
        tp, pp = peak_power(b11, b22, k, x10)
        assert pp == pytest.approx(p_sim, rel=1e-7)
        assert tp == pytest.approx(t_sim, rel=1e-3)
    # The printed imaginary part (2 sqrt(k b11) - b22 k)/2 lacks a square root.
    assert printed_formula_check(1.0, 0.0, 1.0)["eq19.beta"] is False


def test_bad_weights_are_refused():
    for args, field in (((1.0, 0.0, 0.0), "regulator.k"), ((1.0, 0.0, -2.0), "regulator.k"),
                        ((0.0, 1.0, 1.0), "regulator.beta11"), ((-1.0, 1.0, 1.0), "regulator.beta11"),
                        ((1.0, -0.1, 1.0), "regulator.beta22")):
        with pytest.raises(InputError) as e:
            riccati_closed_form(*args)
        assert e.value.field == field
    with pytest.raises(InputError, match="must be > 0"):
        lqr_gain(1.0, 1.0, 0.0)


def test_exact_response_matches_scipy_expm_on_grid():
    from scipy.linalg import expm

    t = np.array([0.0, 0.3, 3.0, 30.0])
    for b11, b22, k in GRID:
        ast = closed_loop_matrix(b11, b22, k)
        ts = t / stability_margin(b11, b22, k)
        ref = np.array([expm(ast * ti) @ [1.0, -0.5] for ti in ts])
        assert response(b11, b22, k, [1.0, -0.5], ts) == pytest.approx(ref, rel=1e-8, abs=1e-12)
