"""Reference models: closed-form torque-free motion and the gyrostat integrator.

Independent numbers: solve_ivp DOP853 (rtol 1e-12, atol 1e-15 |w0|) on Euler's equations
written out here, conservation of energy and |L|, scipy's ellipj, the near-separatrix
expansion of A&S 16.15, the harmonic solution of an axisymmetric body and the linearised
nutation frequency of a spinning gyrostat.
"""

import itertools

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.special import ellipj

from testbed.errors import InputError
from testbed.references import (
    gyrostat_energy,
    gyrostat_momentum,
    gyrostat_omega,
    jacobi_sncndn,
    solve_torque_free,
    torque_free_omega,
)

DEG = np.pi / 180.0
SKYLAB = (1.25e6, 6.9e6, 7.1e6)


def euler_ivp(inertia, w0, t):
    """Euler's equations I_i w_i' = (I_j - I_k) w_j w_k by DOP853 (the second method)."""
    i1, i2, i3 = inertia

    def rhs(_, w):
        return [(i2 - i3) * w[1] * w[2] / i1, (i3 - i1) * w[2] * w[0] / i2,
                (i1 - i2) * w[0] * w[1] / i3]

    sol = solve_ivp(rhs, (0.0, t[-1]), w0, method="DOP853", rtol=1e-12,
                    atol=1e-15 * np.linalg.norm(w0), t_eval=t)
    return sol.y.T


def rel_err(a, b, scale):
    return float(np.max(np.abs(a - b)) / scale)


# ---------------------------------------------------------------- Jacobi functions
def test_jacobi_matches_scipy_for_moderate_m():
    u = np.linspace(-40.0, 40.0, 801)
    for m in (0.0, 0.1, 0.5, 0.9, 0.99):
        ours = jacobi_sncndn(u, 1.0 - m)
        ref = ellipj(u, m)[:3]
        for a, b in zip(ours, ref):
            assert np.max(np.abs(a - b)) < 1e-13  # both carry eps * |u| from the argument


def test_jacobi_near_m_one_matches_ams_16_15():
    # A&S 16.15.1-3: first order in m1 about the separatrix; O(m1^2 cosh^4 u) ~ 1e-14 here.
    m1 = 1e-8
    u = np.linspace(-2.0, 2.0, 81)
    sn, cn, dn = jacobi_sncndn(u, m1)
    q = 0.25 * m1 * (np.sinh(u) * np.cosh(u) - u)
    sech = 1.0 / np.cosh(u)
    assert np.max(np.abs(sn - (np.tanh(u) + q * sech**2))) < 1e-14
    assert np.max(np.abs(cn - (sech - q * np.tanh(u) * sech))) < 1e-14
    r = 0.25 * m1 * (np.sinh(u) * np.cosh(u) + u)
    assert np.max(np.abs(dn - (sech + r * np.tanh(u) * sech))) < 1e-14


# ---------------------------------------------------------------- torque-free body
@pytest.mark.parametrize("w0", [(0.25 * DEG, -0.25 * DEG, 0.0), (0.01, 0.02, 0.3)],
                         ids=["lebedev", "fast_tumble"])
def test_skylab_matches_dop853_over_1000_s(w0):
    t = np.linspace(0.0, 1000.0, 2001)
    closed = torque_free_omega(SKYLAB, w0, t)
    # Measured 1.7e-12 and 1.0e-12; the integrator carries most of it (its error
    # falls with its rtol while the closed form stays put).
    assert rel_err(closed, euler_ivp(SKYLAB, w0, t), np.linalg.norm(w0)) < 5e-12


def test_regimes_reported():
    assert solve_torque_free(SKYLAB, (0.01, 0.02, 0.3)).regime == "major"
    assert solve_torque_free(SKYLAB, (0.25 * DEG, -0.25 * DEG, 0.0)).regime == "minor"
    assert solve_torque_free(SKYLAB, (0.0, 0.0, 0.0)).regime == "equilibrium"


def test_all_orders_and_signs_match_dop853():
    # Every permutation of the inertia order (odd ones make the sorted frame
    # left-handed) and every sign pattern of w0, in both regimes, over 1-2 polhode periods.
    t = np.linspace(0.0, 12.0, 25)
    base_i = np.array([1.0, 2.0, 3.5])
    worst = 0.0
    for base_w in (np.array([0.9, 0.4, 0.3]), np.array([0.2, 0.5, 0.6])):  # minor, major
        for perm in itertools.permutations(range(3)):
            for signs in itertools.product((1.0, -1.0), repeat=3):
                inertia, w0 = base_i[list(perm)], base_w[list(perm)] * np.array(signs)
                closed = torque_free_omega(inertia, w0, t)
                worst = max(worst, rel_err(closed, euler_ivp(inertia, w0, t), 1.0))
    assert worst < 1e-12


def test_random_bodies_match_dop853():
    # The integrator's global error grows with the angle turned: measured
    # max err / (|w0| t_end) = 1e-12 at rtol 1e-12 (3e-14 at rtol 3e-14, while the closed
    # form agrees with a 40-digit evaluation of itself to 2.5e-14), hence the budget.
    rng = np.random.default_rng(20240601)
    t = np.linspace(0.0, 100.0, 101)
    regimes = set()
    for _ in range(12):
        inertia = rng.uniform(1.0, 10.0, 3)
        w0 = rng.normal(size=3)
        regimes.add(solve_torque_free(inertia, w0).regime)
        closed = torque_free_omega(inertia, w0, t)
        budget = 2e-12 * (1.0 + np.linalg.norm(w0) * t[-1])
        assert rel_err(closed, euler_ivp(inertia, w0, t), np.linalg.norm(w0)) < budget
    assert regimes == {"major", "minor"}


def test_odd_relabelling_reverses_time_and_cyclic_keeps_it():
    inertia, w0 = np.array([2.0, 5.0, 3.0]), np.array([0.3, -0.2, 0.5])
    t = np.linspace(0.0, 50.0, 51)
    ref = torque_free_omega(inertia, w0, t)
    cyc = [1, 2, 0]
    assert np.allclose(torque_free_omega(inertia[cyc], w0[cyc], t)[:, np.argsort(cyc)],
                       ref, rtol=0, atol=1e-14)
    odd = [1, 0, 2]  # a left-handed relabelling: Euler's equations run backwards
    assert np.allclose(torque_free_omega(inertia[odd], w0[odd], -t)[:, np.argsort(odd)],
                       ref, rtol=0, atol=1e-14)


def test_energy_and_momentum_conserved_by_closed_form():
    inertia, w0 = np.array([3.0, 1.0, 2.0]), np.array([0.7, -1.1, 0.4])
    w = torque_free_omega(inertia, w0, np.linspace(0.0, 1e4, 5001))
    energy = 0.5 * (w**2) @ inertia
    momentum = np.linalg.norm(w * inertia, axis=1)
    assert np.ptp(energy) / energy[0] < 1e-14
    assert np.ptp(momentum) / momentum[0] < 1e-14


@pytest.mark.parametrize("delta", [1e-2, -1e-4, 1e-6, -1e-8])
def test_near_separatrix_matches_dop853(delta):
    # S = L^2 - 2T I_mid = delta * I_c (I_c - I_b) w_c^2; 1 - m ~ 0.27 delta here.
    # Measured errors: 3.2e-12, 9.5e-11, 4.5e-11, 2.3e-07 over 200 s; they are the
    # integrator's (its energy error of ~1e-12 moves the polhode period by ~1e-12/delta),
    # the closed form matches a 40-digit evaluation to 1e-13 down to 1 - m = 3e-15.
    inertia = (1.0, 2.0, 3.0)
    w0 = (0.3, 0.5, -0.3 * np.sqrt((1.0 + delta) / 3.0))
    t = np.linspace(0.0, 200.0, 201)
    closed = torque_free_omega(inertia, w0, t)
    tol = 1e-11 + 3e-14 / abs(delta)
    assert rel_err(closed, euler_ivp(inertia, w0, t), np.linalg.norm(w0)) < tol


def test_separatrix_sech_tanh():
    # On the separatrix (L^2 = 2T I_b): w_a = alpha sech u, w_b = beta tanh u,
    # w_c = gamma sech u with beta^2 = 2T / I_b, alpha^2 = 2T (I_c - I_b) / (I_a (I_c - I_a)),
    # gamma^2 = 2T (I_b - I_a) / (I_c (I_c - I_a)) (Landau & Lifshitz §37).  Compared with
    # the integrator until the saddle approach, after which rounding decides the future.
    inertia = np.array([3.0, 1.0, 2.0])  # major = axis 0, minor = axis 1, intermediate = 2
    i_a, i_b, i_c, two_t = 1.0, 2.0, 3.0, 0.32
    beta = np.sqrt(two_t / i_b)
    alpha = np.sqrt(two_t * (i_c - i_b) / (i_a * (i_c - i_a)))
    gamma = np.sqrt(two_t * (i_b - i_a) / (i_c * (i_c - i_a)))
    u0 = -3.0
    w0 = np.array([-gamma, alpha, 0.0]) / np.cosh(u0)
    w0[2] = beta * np.tanh(u0)
    sol = solve_torque_free(inertia, w0)
    assert sol.regime == "separatrix"
    t = np.linspace(0.0, 40.0, 81)
    closed = sol.omega(t)
    assert rel_err(closed, euler_ivp(inertia, w0, t), np.linalg.norm(w0)) < 1e-11
    assert closed[-1, 2] == pytest.approx(-beta, rel=1e-6)  # tends to the saddle


@pytest.mark.parametrize("inertia", [(2.0, 2.0, 3.0), (3.0, 3.0, 1.0), (4.0, 1.5, 4.0)],
                         ids=["oblate", "prolate", "oblate_axis1"])
def test_axisymmetric_harmonic_precession(inertia):
    # Symmetry axis k, equal moments I_t on axes i, j = k+1, k+2: w_k constant and
    # w_i + i w_j = (w_i + i w_j)(0) exp(i (I_k - I_t)/I_t w_k t) (Landau & Lifshitz §33).
    inertia = np.array(inertia)
    k = next(n for n in range(3) if inertia[n] != inertia[(n + 1) % 3]
             and inertia[n] != inertia[(n + 2) % 3])
    i, j = (k + 1) % 3, (k + 2) % 3
    w0 = np.array([0.0, 0.0, 0.0])
    w0[[i, j, k]] = (0.2, -0.1, 0.5)
    t = np.linspace(0.0, 500.0, 1001)
    rate = (inertia[k] - inertia[i]) / inertia[i] * w0[k]
    z = (w0[i] + 1j * w0[j]) * np.exp(1j * rate * t)
    closed = torque_free_omega(inertia, w0, t)
    assert solve_torque_free(inertia, w0).m == 0.0
    assert np.max(np.abs(closed[:, i] - z.real)) < 1e-13
    assert np.max(np.abs(closed[:, j] - z.imag)) < 1e-13
    assert np.max(np.abs(closed[:, k] - w0[k])) < 1e-15


@pytest.mark.parametrize("inertia, w0", [
    (SKYLAB, (0.0, 0.0, 0.0)),
    ((5.0, 5.0, 5.0), (0.1, -0.3, 0.2)),
    (SKYLAB, (0.2, 0.0, 0.0)),
    (SKYLAB, (0.0, -0.2, 0.0)),  # intermediate axis: unstable, yet an equilibrium
    (SKYLAB, (0.0, 0.0, 0.2)),
    ((2.0, 2.0, 3.0), (0.1, 0.3, 0.0)),  # any axis in the equal-moment plane
])
def test_equilibria_are_constant(inertia, w0):
    t = np.linspace(0.0, 1000.0, 11)
    assert solve_torque_free(inertia, w0).regime == "equilibrium"
    assert np.array_equal(torque_free_omega(inertia, w0, t), np.tile(w0, (11, 1)))


@pytest.mark.parametrize("inertia, w0", [((1.0, -2.0, 3.0), (0, 0, 0)), ((1.0, 2.0), (0, 0, 0)),
                                         ((1.0, 2.0, 3.0), (0.0, np.nan, 0.0))])
def test_torque_free_bad_input(inertia, w0):
    with pytest.raises(InputError):
        torque_free_omega(inertia, w0, [0.0])


# ---------------------------------------------------------------- gyrostat
def test_gyrostat_without_rotor_is_the_rigid_body():
    t = np.linspace(0.0, 1000.0, 501)
    w0 = (0.01, 0.02, 0.3)
    num = gyrostat_omega(SKYLAB, (0.0, 0.0, 0.0), w0, t)
    assert rel_err(num, torque_free_omega(SKYLAB, w0, t), np.linalg.norm(w0)) < 5e-12


def test_gyrostat_full_tensor_is_a_rotated_rigid_body():
    # I = R diag R^T: w(t) = R w_principal(t) with w_principal from the closed form.
    ang = 0.7
    r = np.array([[np.cos(ang), -np.sin(ang), 0.0], [np.sin(ang), np.cos(ang), 0.0], [0, 0, 1]])
    r = r @ np.array([[1, 0, 0], [0, np.cos(0.3), -np.sin(0.3)], [0, np.sin(0.3), np.cos(0.3)]])
    principal = np.array([2.0, 3.0, 4.5])
    tensor = r @ np.diag(principal) @ r.T
    tensor = 0.5 * (tensor + tensor.T)
    w0 = np.array([0.3, -0.4, 0.5])
    t = np.linspace(0.0, 100.0, 201)
    num = gyrostat_omega(tensor, np.zeros(3), w0, t)
    closed = torque_free_omega(principal, r.T @ w0, t) @ r.T
    assert rel_err(num, closed, np.linalg.norm(w0)) < 1e-11


def test_gyrostat_constant_rotor_conserves_energy_and_momentum():
    rng = np.random.default_rng(7)
    a = rng.normal(size=(3, 3))
    tensor = a @ a.T + 2.0 * np.eye(3)
    h = np.array([0.5, -1.2, 2.0])
    t = np.linspace(0.0, 200.0, 401)
    w = gyrostat_omega(tensor, h, (0.3, 0.1, -0.2), t)
    mom = np.linalg.norm(gyrostat_momentum(tensor, h, w), axis=1)
    energy = gyrostat_energy(tensor, w)
    assert np.ptp(mom) / mom[0] < 1e-11
    assert np.ptp(energy) / energy[0] < 1e-11
    assert np.ptp(w[:, 0]) > 0.1  # the motion is not trivial


def test_gyrostat_spin_about_aligned_rotor_axis_is_constant():
    t = np.linspace(0.0, 100.0, 11)
    w = gyrostat_omega(SKYLAB, (0.0, 5e3, 0.0), (0.0, 0.02, 0.0), t)
    assert np.array_equal(w, np.tile([0.0, 0.02, 0.0], (11, 1)))


@pytest.mark.parametrize("inertia, spin, h_axial", [
    ((2.0, 3.0, 4.0), 0.5, 1.0),   # major-axis spin, rotor adds to the stiffness
    ((4.0, 3.0, 2.0), 0.5, 3.0),   # minor-axis spin made stable by the rotor (dual spin)
])
def test_gyrostat_nutation_frequency_matches_linearisation(inertia, spin, h_axial):
    # Spin w = (0, 0, W) with rotor h = (0, 0, h): linearising I w' = -w x (I w + h),
    # I1 dw1' = ((I2 - I3) W - h) dw2, I2 dw2' = ((I3 - I1) W + h) dw1, so
    # wn^2 = ((I3 - I2) W + h)((I3 - I1) W + h) / (I1 I2) (Hughes, Spacecraft Attitude
    # Dynamics, §7.2, dual-spin stability).
    i1, i2, i3 = inertia
    k1 = ((i2 - i3) * spin - h_axial) / i1
    k2 = ((i3 - i1) * spin + h_axial) / i2
    wn = np.sqrt(-k1 * k2)
    eps = 1e-7
    t = np.linspace(0.0, 10 * 2 * np.pi / wn, 401)
    w = gyrostat_omega(inertia, (0.0, 0.0, h_axial), (eps, 0.0, spin), t)
    lin1 = eps * np.cos(wn * t)
    lin2 = eps * (k2 / wn) * np.sin(wn * t)
    # Nonlinear terms are O(eps^2); a 1e-6 error in wn would leave ~6e-5 eps after 10 cycles.
    assert np.max(np.abs(w[:, 0] - lin1)) < 1e-6 * eps
    assert np.max(np.abs(w[:, 1] - lin2)) < 1e-6 * eps * abs(k2 / wn) + 1e-6 * eps


def test_gyrostat_time_varying_rotor_momentum_exchange():
    # Spin and rotor on the same principal axis: I3 w3' = -h3', so
    # w3(t) = w3(0) - (h3(t) - h3(0)) / I3 exactly (a reaction wheel spinning up).
    h = lambda t: np.array([0.0, 0.0, 2e4 * np.sin(0.05 * t)])
    hd = lambda t: np.array([0.0, 0.0, 2e4 * 0.05 * np.cos(0.05 * t)])
    t = np.linspace(0.0, 300.0, 301)
    w = gyrostat_omega(SKYLAB, h, (0.0, 0.0, 0.01), t, h_dot=hd)
    expect = 0.01 - 2e4 * np.sin(0.05 * t) / SKYLAB[2]
    assert np.max(np.abs(w[:, 2] - expect)) < 1e-14
    assert np.max(np.abs(w[:, :2])) == 0.0


def test_gyrostat_time_varying_rotor_conserves_momentum_magnitude():
    h = lambda t: np.array([1.0 * np.cos(0.3 * t), 0.5 * t / (1.0 + t), 2.0])
    hd = lambda t: np.array([-0.3 * np.sin(0.3 * t), 0.5 / (1.0 + t) ** 2, 0.0])
    t = np.linspace(0.0, 100.0, 201)
    w = gyrostat_omega((2.0, 3.0, 4.0), h, (0.2, -0.3, 0.4), t, h_dot=hd)
    mom = np.linalg.norm(gyrostat_momentum((2.0, 3.0, 4.0), np.array([h(s) for s in t]), w),
                         axis=1)
    assert np.ptp(mom) / mom[0] < 1e-11
    energy = gyrostat_energy((2.0, 3.0, 4.0), w)
    assert np.ptp(energy) > 1e-3  # energy is exchanged with the rotor


@pytest.mark.parametrize("kwargs", [
    dict(inertia=np.array([[1, 0.5, 0], [0, 1, 0], [0, 0, 1]]), h_body=(0, 0, 0)),
    dict(inertia=np.diag([1.0, -1.0, 1.0]), h_body=(0, 0, 0)),
    dict(inertia=(1.0, 2.0, 3.0), h_body=lambda t: np.zeros(3)),
    dict(inertia=(1.0, 2.0, 3.0), h_body=(0, 0, 0), t=[1.0, 0.5]),
])
def test_gyrostat_bad_input(kwargs):
    args = dict(omega0=(0.1, 0.0, 0.0), t=[0.0, 1.0])
    args.update(kwargs)
    with pytest.raises(InputError):
        gyrostat_omega(**args)
