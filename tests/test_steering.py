"""Steering laws (SEEDS §004 eq. (17)-(28)) checked against independent computations."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.optimize import linprog

from testbed.errors import InputError
from testbed.steering import (STEERING_LAWS, gsr_steering, minimax_lp_steering,
                              minimax_steering, pinv_steering, sr_steering, steer)
from rhombus_reference import rhombus_column_derivative, rhombus_jacobian, rhombus_momentum

ALPHA = math.radians(50.0)
LAWS = sorted(STEERING_LAWS)
# Laws whose command is a fixed linear (min-max: positively homogeneous) function of the demand;
# minimax_avoid's barrier depends on the configuration, not on the demand's size.
HOMOGENEOUS_LAWS = [law for law in LAWS if law != "minimax_avoid"]


def random_case(rng):
    """(beta, alpha, h, Hdot): random gimbal angles and skew, demand magnitudes over four decades."""
    return (rng.uniform(-np.pi, np.pi, 4), rng.uniform(0.3, 1.2), rng.uniform(1.0, 50.0),
            rng.normal(size=3) * 10.0 ** rng.uniform(-2, 2))


def random_problem(rng):
    """(J, h, Hdot) of random_case."""
    beta, alpha, h, hdot = random_case(rng)
    return rhombus_jacobian(beta, alpha), h, hdot


def steer_at(law, beta, alpha, h, hdot, limit, **options):
    """steer(law, ...) at gimbal angles beta, with the step inputs the law takes (dJ_i/dbeta_i)."""
    if law == "minimax_avoid":
        options["column_derivative"] = rhombus_column_derivative(beta, alpha)
    return steer(law, rhombus_jacobian(beta, alpha), h, hdot, limit, **options)


def singular_betas(rng):
    """Gimbal sets where rank J < 3: zero (rank 1), beta1 = beta3 & beta2 = beta4 (rank 2,
    H = 0) and the z-saturation (90, 90, -90, -90) deg (rank 2)."""
    b1, b2 = rng.uniform(-np.pi, np.pi, 2)
    return [np.zeros(4), np.array([b1, b2, b1, b2]), np.radians([90.0, 90.0, -90.0, -90.0])]


def lstsq_projection(J, b):
    """Least-squares projection of b onto range(J) by numpy's lstsq (independent of the SVD path)."""
    x, *_ = np.linalg.lstsq(J, b, rcond=1e-9)
    return J @ x


# --- geometry ------------------------------------------------------------------------------

def test_rhombus_jacobian_is_the_derivative_of_eq15():
    rng = np.random.default_rng(1)
    beta, step = rng.uniform(-np.pi, np.pi, 4), 1e-6
    numeric = np.column_stack([(rhombus_momentum(beta + step * e, ALPHA)
                                - rhombus_momentum(beta - step * e, ALPHA)) / (2 * step)
                               for e in np.eye(4)])
    np.testing.assert_allclose(rhombus_jacobian(beta, ALPHA), numeric, atol=1e-9)


# --- pseudo-inverse and SR inverses -------------------------------------------------------

def test_pinv_equals_lstsq_minimum_norm_solution():
    rng = np.random.default_rng(2)
    for _ in range(200):
        J, h, hdot = random_problem(rng)
        result = pinv_steering(J, h, hdot, np.inf)
        expected, *_ = np.linalg.lstsq(J, hdot / h, rcond=None)
        np.testing.assert_allclose(result.beta_rate, expected, rtol=1e-9, atol=1e-12 * np.abs(expected).max())
        np.testing.assert_allclose(result.hdot_delivered, hdot, atol=1e-9 * np.linalg.norm(hdot))
        assert result.scale == 1.0 and result.status == "ok"
        assert result.singularity_measure == pytest.approx(math.sqrt(np.linalg.det(J @ J.T)), rel=1e-9)


def test_sr_is_the_damped_least_squares_solution_below_m0():
    rng = np.random.default_rng(3)
    lambda0, m0, checked = 0.05, 0.5, 0
    while checked < 100:
        J, h, hdot = random_problem(rng)
        m = math.sqrt(np.linalg.det(J @ J.T))
        result = sr_steering(J, h, hdot, np.inf, lambda0=lambda0, m0=m0)
        if m >= m0:  # undamped: the pseudo-inverse exactly
            np.testing.assert_allclose(result.beta_rate, np.linalg.pinv(J) @ hdot / h, rtol=1e-9)
            continue
        lam = lambda0 * (1 - m / m0) ** 2
        # Push-through identity: J^T (J J^T + lam I)^-1 = (J^T J + lam I)^-1 J^T.
        expected = np.linalg.solve(J.T @ J + lam * np.eye(4), J.T @ hdot / h)
        np.testing.assert_allclose(result.beta_rate, expected, rtol=1e-8, atol=1e-12 * np.abs(expected).max())
        checked += 1


def wie_E(t, eps0=0.01, omega=math.pi / 2, phases=(0.0, math.pi / 2, math.pi)):
    e = [eps0 * math.sin(omega * t + p) for p in phases]
    return np.array([[1, e[2], e[1]], [e[2], 1, e[0]], [e[1], e[0], 1]])


def test_gsr_solves_the_dithered_damped_equation():
    rng = np.random.default_rng(4)
    for _ in range(100):
        J, h, hdot = random_problem(rng)
        t = rng.uniform(0, 10)
        beta_rate = gsr_steering(J, h, hdot, np.inf, t=t).beta_rate
        # beta' = J^T y: recover y by least squares, then check (J J^T + lam E) y = b.
        y, *_ = np.linalg.lstsq(J.T, beta_rate, rcond=None)
        np.testing.assert_allclose(J.T @ y, beta_rate, atol=1e-10 * np.abs(beta_rate).max())
        lam = 0.01 * math.exp(-10.0 * np.linalg.det(J @ J.T))
        np.testing.assert_allclose((J @ J.T + lam * wie_E(t)) @ y, hdot / h,
                                   atol=1e-10 * np.linalg.norm(hdot / h))


def test_gsr_dither_escapes_where_sr_is_stuck():
    # Internal singularity beta1 = beta3, beta2 = beta4: a demand along the singular direction
    # u3 (left null vector of J) gets zero rates from SR, but not from Wie's dithered GSR.
    J = rhombus_jacobian(np.array([0.4, -1.1, 0.4, -1.1]), ALPHA)
    u3 = np.linalg.svd(J)[0][:, 2]
    sr = sr_steering(J, 10.0, 3.0 * u3, 1.0, lambda0=0.01, m0=0.2)
    gsr = gsr_steering(J, 10.0, 3.0 * u3, 1.0, t=0.5)
    assert np.abs(sr.beta_rate).max() < 1e-12
    assert np.abs(gsr.beta_rate).max() > 1e-3
    # Its rates leave the singular set: the delivered H' = J b' is orthogonal to u3 to round-off
    # (its sign along u3 was the machine's), but a 1 s step along b' takes the singularity
    # measure sqrt(det(J J^T)) from round-off to the order of the step (well conditioned).
    def measure(beta):
        jac = rhombus_jacobian(beta, ALPHA)
        return math.sqrt(max(np.linalg.det(jac @ jac.T), 0.0))

    beta = np.array([0.4, -1.1, 0.4, -1.1])
    assert measure(beta) < 1e-6  # sqrt of a round-off determinant: 1.5e-8 here
    assert measure(beta + gsr.beta_rate * 1.0) > 1e-3  # 3.6e-3 here, 2.5 |b'|max


# --- min-max: exact closed form vs linear programs -----------------------------------------

def batched_minimax_lp(Js, b):
    """Optimal max|beta'_i| of N independent epigraph LPs, solved as one separable LP
    (minimising the sum of the s_k minimises each s_k): one HiGHS call for all cases."""
    n = len(Js)
    rows = (3 * np.arange(n)[:, None, None] + np.arange(3)[None, :, None]).repeat(4, 2)
    cols = (5 * np.arange(n)[:, None, None] + np.arange(4)[None, None, :]).repeat(3, 1)
    a_eq = sp.csr_matrix((Js.ravel(), (rows.ravel(), cols.ravel())), shape=(3 * n, 5 * n))
    block = np.block([[np.eye(4), -np.ones((4, 1))], [-np.eye(4), -np.ones((4, 1))]])
    a_ub = sp.kron(sp.eye(n), sp.csr_matrix(block), format="csr")
    res = linprog(np.tile([0, 0, 0, 0, 1.0], n), A_ub=a_ub, b_ub=np.zeros(8 * n), A_eq=a_eq,
                  b_eq=b.ravel(), bounds=[(None, None)] * (5 * n), method="highs",
                  options={"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10})
    assert res.status == 0, res.message
    return np.abs(res.x.reshape(n, 5)[:, :4]).max(axis=1)


@pytest.mark.slow
def test_exact_minimax_equals_lp_on_10000_random_cases():
    rng = np.random.default_rng(5)
    n = 10_000
    problems = [random_problem(rng) for _ in range(n)]
    Js = np.array([J for J, _, _ in problems])
    b = np.array([hdot / h for _, h, hdot in problems])
    s_lp = batched_minimax_lp(Js, b)
    worst_value, worst_residual = 0.0, 0.0
    for (J, h, hdot), s in zip(problems, s_lp):
        result = minimax_steering(J, h, hdot, np.inf)
        worst_value = max(worst_value, abs(np.abs(result.beta_rate).max() - s) / s)
        worst_residual = max(worst_residual,
                             np.linalg.norm(h * J @ result.beta_rate - hdot) / np.linalg.norm(hdot))
    assert worst_value < 1e-9, worst_value
    assert worst_residual < 1e-9, worst_residual


def test_lp_forms_epigraph_and_paper_agree_with_exact():
    rng = np.random.default_rng(6)
    for _ in range(100):
        J, h, hdot = random_problem(rng)
        exact = minimax_steering(J, h, hdot, np.inf)
        s = np.abs(exact.beta_rate).max()
        for form in ("epigraph", "paper"):
            lp = minimax_lp_steering(J, h, hdot, np.inf, form=form)
            assert np.abs(lp.beta_rate).max() == pytest.approx(s, rel=1e-9)
            np.testing.assert_allclose(h * J @ lp.beta_rate, hdot, atol=1e-9 * np.linalg.norm(hdot))


def test_minimax_never_worse_than_pinv():
    # Both satisfy J beta' = b; min-max minimises the largest rate, pinv the 2-norm.
    rng = np.random.default_rng(7)
    for _ in range(500):
        J, h, hdot = random_problem(rng)
        assert (np.abs(minimax_steering(J, h, hdot, np.inf).beta_rate).max()
                <= np.abs(pinv_steering(J, h, hdot, np.inf).beta_rate).max() * (1 + 1e-12))


def test_zero_null_vector_component_is_handled():
    # A J whose null vector has an exact zero: gimbal 1 is pinned, |beta'_1| is a constant line.
    J = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0]])
    hdot = np.array([3.0, 1.0, -2.0])
    # Null space is (0, -1, -1, 1): beta1 = 3 fixed, others (1 - t, -2 - t, t): optimum is 3.
    result = minimax_steering(J, 1.0, hdot, np.inf)
    lp = minimax_lp_steering(J, 1.0, hdot, np.inf)
    assert np.abs(result.beta_rate).max() == pytest.approx(np.abs(lp.beta_rate).max(), rel=1e-12)
    assert np.abs(result.beta_rate).max() == pytest.approx(3.0, rel=1e-12)
    np.testing.assert_allclose(J @ result.beta_rate, hdot, atol=1e-12)


# --- rate limit ---------------------------------------------------------------------------

@pytest.mark.parametrize("law", HOMOGENEOUS_LAWS)
def test_rate_limit_never_exceeded_and_scale_is_exact(law):
    rng = np.random.default_rng(8)
    beta_rate_max = 0.3
    for i in range(150):
        J, h, hdot = random_problem(rng)
        if i % 3 == 0:  # a third of the cases within 1e-8 of a singular set
            J = rhombus_jacobian(singular_betas(rng)[(i // 3) % 3] + 1e-8 * rng.normal(size=4),
                                 ALPHA)
        free = steer(law, J, h, hdot, np.inf)
        limited = steer(law, J, h, hdot, beta_rate_max)
        peak = np.abs(free.beta_rate).max()
        assert np.all(np.isfinite(limited.beta_rate))
        assert np.abs(limited.beta_rate).max() <= beta_rate_max
        # Every law is linear (min-max: positively homogeneous) in the demand, so the limited
        # command is the free one scaled by k = beta_rate_max / peak.
        k = min(1.0, beta_rate_max / peak) if peak > 0 else 1.0
        assert limited.scale == pytest.approx(k, rel=1e-12)
        np.testing.assert_allclose(limited.beta_rate, k * free.beta_rate,
                                   rtol=1e-9, atol=1e-12 * beta_rate_max)
        np.testing.assert_allclose(limited.hdot_delivered, h * J @ limited.beta_rate, rtol=1e-12,
                                   atol=1e-15 * h)
        assert ("rate_limited" in limited.status) == (k < 1.0)


def test_rate_limited_minimax_hits_the_limit_exactly():
    rng = np.random.default_rng(9)
    for _ in range(200):
        J, h, hdot = random_problem(rng)
        s = np.abs(minimax_lp_steering(J, h, hdot, np.inf).beta_rate).max()
        limit = 0.5 * s
        result = minimax_steering(J, h, hdot, limit)
        assert result.scale == pytest.approx(0.5, rel=1e-9)
        assert np.abs(result.beta_rate).max() == pytest.approx(limit, rel=1e-12)
        np.testing.assert_allclose(result.hdot_delivered, 0.5 * hdot, atol=1e-9 * np.linalg.norm(hdot))


# --- singular and near-singular gimbal sets -----------------------------------------------

@pytest.mark.parametrize("law", LAWS)
def test_singular_sets_give_bounded_least_squares_commands(law):
    rng = np.random.default_rng(10)
    for _ in range(10):
        for beta, rank in zip(singular_betas(rng), (1, 2, 2)):
            J = rhombus_jacobian(beta, ALPHA)
            h, hdot, limit = 20.0, rng.normal(size=3) * 5.0, 0.5
            result = steer_at(law, beta, ALPHA, h, hdot, limit)
            assert np.all(np.isfinite(result.beta_rate)) and np.all(np.isfinite(result.hdot_delivered))
            assert np.abs(result.beta_rate).max() <= limit
            assert result.rank == rank and "rank_deficient" in result.status
            assert result.singularity_measure < 1e-12
            if law in ("pinv", "minimax", "minimax_lp", "minimax_avoid"):
                # Delivered = k * (least-squares projection of H' onto range J).
                projection = h * lstsq_projection(J, hdot / h)
                np.testing.assert_allclose(result.hdot_delivered, result.scale * projection,
                                           atol=1e-9 * np.linalg.norm(hdot))
            else:  # damped: never pushes against the demand
                assert np.dot(result.hdot_delivered, hdot) >= 0


def test_singular_minimax_matches_epigraph_lp_and_beats_pinv():
    # Null-space LP (default) vs the epigraph LP on the projected demand: two LP forms.
    rng = np.random.default_rng(11)
    for _ in range(20):
        for beta in singular_betas(rng):
            J, hdot = rhombus_jacobian(beta, ALPHA), rng.normal(size=3)
            exact = np.abs(minimax_steering(J, 1.0, hdot, np.inf).beta_rate).max()
            pinv = np.abs(pinv_steering(J, 1.0, hdot, np.inf).beta_rate).max()
            lp = np.abs(minimax_lp_steering(J, 1.0, hdot, np.inf, form="epigraph").beta_rate).max()
            assert exact == pytest.approx(lp, rel=1e-9)
            assert exact <= pinv * (1 + 1e-9)


@pytest.mark.parametrize("law", LAWS)
def test_within_1e8_of_singular_commands_stay_finite_and_on_direction(law):
    rng = np.random.default_rng(12)
    for _ in range(30):
        for beta in singular_betas(rng):
            beta = beta + 1e-8 * rng.normal(size=4)
            h, hdot, limit = 20.0, rng.normal(size=3), 1.0
            result = steer_at(law, beta, ALPHA, h, hdot, limit)
            assert np.all(np.isfinite(result.beta_rate)) and np.all(np.isfinite(result.hdot_delivered))
            assert np.abs(result.beta_rate).max() <= limit
            if law in ("pinv", "minimax", "minimax_lp", "minimax_avoid") and result.rank == 3:
                # Exact-tracking laws keep the demand's direction: delivered = k H' (to cond(J) eps).
                np.testing.assert_allclose(result.hdot_delivered, result.scale * hdot,
                                           atol=1e-6 * result.scale * np.linalg.norm(hdot))


def test_near_singular_minimax_exact_matches_paper_lp():
    rng = np.random.default_rng(14)
    for _ in range(20):
        for beta in singular_betas(rng):
            J, hdot = rhombus_jacobian(beta + 1e-8 * rng.normal(size=4), ALPHA), rng.normal(size=3)
            exact = minimax_steering(J, 1.0, hdot, np.inf)
            lp = minimax_lp_steering(J, 1.0, hdot, np.inf, form="paper")
            assert exact.rank == lp.rank  # 3, or 2 when sigma_3 <= 1e-9 sigma_1 (near beta = 0)
            assert np.abs(exact.beta_rate).max() == pytest.approx(np.abs(lp.beta_rate).max(), rel=1e-6)


# --- registry and input checks ------------------------------------------------------------

def test_registry_runs_the_named_law_with_its_options():
    rng = np.random.default_rng(13)
    J, h, hdot = random_problem(rng)
    np.testing.assert_array_equal(steer("gsr", J, h, hdot, 1.0, t=2.0).beta_rate,
                                  gsr_steering(J, h, hdot, 1.0, t=2.0).beta_rate)
    np.testing.assert_array_equal(steer("minimax_lp", J, h, hdot, 1.0, form="paper").beta_rate,
                                  minimax_lp_steering(J, h, hdot, 1.0, form="paper").beta_rate)


@pytest.mark.parametrize("call, field", [
    (lambda J: steer("minimax", J, 1.0, [1, 0, 0], 0.0), "steering.beta_rate_max"),
    (lambda J: steer("pinv", J, 1.0, [1, 0, 0], -1.0), "steering.beta_rate_max"),
    (lambda J: steer("sr", J, 1.0, [1, 0, 0], float("nan")), "steering.beta_rate_max"),
    (lambda J: steer("minimax", J, 0.0, [1, 0, 0], 1.0), "steering.h"),
    (lambda J: steer("minimax", J[:, :2], 1.0, [1, 0, 0], 1.0), "steering.J"),  # 3 ... 8 units
    (lambda J: steer("minimax", J * np.nan, 1.0, [1, 0, 0], 1.0), "steering.J"),
    (lambda J: steer("pinv", J, 1.0, [1, 0], 1.0), "steering.Hdot"),
    (lambda J: steer("pinv", J, 1.0, [1, 0, np.inf], 1.0), "steering.Hdot"),
    (lambda J: steer("nope", J, 1.0, [1, 0, 0], 1.0), "steering.law"),
    (lambda J: steer("pinv", J, 1.0, [1, 0, 0], 1.0, t=1.0), "steering.t"),
    (lambda J: steer("minimax_lp", J, 1.0, [1, 0, 0], 1.0, form="dual"), "steering.form"),
    (lambda J: steer("gsr", J, 1.0, [1, 0, 0], 1.0, epsilon0=0.5), "steering.epsilon0"),
    (lambda J: steer("sr", J, 1.0, [1, 0, 0], 1.0, m0=0.0), "steering.m0"),
])
def test_bad_input_names_the_field(call, field):
    J = rhombus_jacobian(np.array([0.1, 0.2, 0.3, 0.4]), ALPHA)
    with pytest.raises(InputError) as err:
        call(J)
    assert err.value.field == field
