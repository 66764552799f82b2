"""The singularity-avoiding min-max law (testbed/steering/minimax_avoid.py) against independent
numbers: scipy's LP with the same linearised barrier, a finite-difference gradient of
sqrt(det(J J^T)), the torque equation h J beta' = H' and the null space of J."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import null_space
from scipy.optimize import linprog

from testbed.errors import InputError
from testbed.steering import minimax_avoid_steering, minimax_steering
from rhombus_reference import rhombus_column_derivative, rhombus_jacobian

HIGHS = {"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10}


def measure(beta, alpha):
    J = rhombus_jacobian(beta, alpha)
    return math.sqrt(max(np.linalg.det(J @ J.T), 0.0))


def numeric_gradient(beta, alpha, step=1e-6):
    """d sqrt(det(J J^T)) / d beta by central differences of the reference Jacobian."""
    return np.array([(measure(beta + step * e, alpha) - measure(beta - step * e, alpha)) / (2 * step)
                     for e in np.eye(4)])


def random_case(rng):
    """Gimbal angles, skew, h, demand, rate limit, floor and gain spread so that the barrier is
    inactive, active and unreachable in comparable numbers."""
    beta = rng.uniform(-np.pi, np.pi, 4)
    alpha = rng.uniform(0.4, 1.2)
    h = rng.uniform(1.0, 50.0)
    hdot = rng.normal(size=3) * h * rng.uniform(0.01, 0.3)
    return beta, alpha, h, hdot, rng.uniform(0.2, 1.0), rng.uniform(0.2, 1.5), rng.uniform(0.1, 3.0)


def random_cases(rng, count, min_measure=1e-3):
    """random_case draws at least min_measure from a singular set (count draws, some skipped)."""
    for _ in range(count):
        case = random_case(rng)
        if measure(case[0], case[1]) >= min_measure:
            yield case


def avoid(beta, alpha, h, hdot, limit, **options):
    """minimax_avoid_steering at gimbal angles beta, with the reference's dJ_i/dbeta_i."""
    return minimax_avoid_steering(rhombus_jacobian(beta, alpha), h, hdot, limit,
                                  column_derivative=rhombus_column_derivative(beta, alpha), **options)


def lp_with_barrier(J, b, g, c, limit):
    """min s over (beta', s): J beta' = b, |beta'_i| <= s, |beta'_i| <= limit, g . beta' >= c."""
    a_ub = np.block([[np.eye(4), -np.ones((4, 1))], [-np.eye(4), -np.ones((4, 1))],
                     [-g[None, :], np.zeros((1, 1))]])
    res = linprog(np.r_[np.zeros(4), 1.0], A_ub=a_ub, b_ub=np.r_[np.zeros(8), -c],
                  A_eq=np.hstack([J, np.zeros((3, 1))]), b_eq=b,
                  bounds=[(-limit, limit)] * 4 + [(0, None)], method="highs", options=HIGHS)
    return res


def lp_best_barrier_rate(J, b, g, limit):
    """max g . beta' over J beta' = b, |beta'_i| <= limit (the most dm/dt the limit allows)."""
    res = linprog(-g, A_eq=J, b_eq=b, bounds=[(-limit, limit)] * 4, method="highs", options=HIGHS)
    return res


def test_gradient_of_the_measure_matches_finite_differences():
    from testbed.steering.least_squares import jacobian_svd
    from testbed.steering.minimax_avoid import measure_gradient

    rng = np.random.default_rng(20)
    for _ in range(200):
        beta, alpha = rng.uniform(-np.pi, np.pi, 4), rng.uniform(0.3, 1.2)
        if measure(beta, alpha) < 1e-3:
            continue
        svd = jacobian_svd(rhombus_jacobian(beta, alpha))
        analytic = measure_gradient(svd, rhombus_column_derivative(beta, alpha))
        np.testing.assert_allclose(analytic, numeric_gradient(beta, alpha), atol=1e-8)


def test_equals_scipy_lp_with_the_same_linearised_barrier_on_random_problems():
    rng = np.random.default_rng(21)
    seen = {"inactive": 0, "active": 0, "avoidance_limited": 0, "rate_limited": 0}
    for beta, alpha, h, hdot, limit, floor, gain in random_cases(rng, 600):
        J, b = rhombus_jacobian(beta, alpha), hdot / h
        g = numeric_gradient(beta, alpha)
        c = -gain * (measure(beta, alpha) - floor)
        result = avoid(beta, alpha, h, hdot, limit, measure_floor=floor, barrier_gain_per_s=gain)
        peak = np.abs(result.beta_rate).max()
        lp = lp_with_barrier(J, b, g, c, limit)
        if lp.status == 0:  # the barrier can be met within the limit: the same min-max value
            assert result.status == "ok"
            assert peak == pytest.approx(lp.fun, rel=1e-7, abs=1e-12)
            assert g @ result.beta_rate >= c - 1e-7 * (1 + abs(c))
            free = np.abs(minimax_steering(J, h, hdot, np.inf).beta_rate).max()
            seen["inactive" if peak <= free * (1 + 1e-9) else "active"] += 1
            continue
        best = lp_best_barrier_rate(J, b, g, limit)
        if best.status == 0:  # exact torque is possible, the barrier is not: the most dm/dt
            assert result.status == "avoidance_limited"
            assert g @ result.beta_rate == pytest.approx(-best.fun, rel=1e-6, abs=1e-9)
            seen["avoidance_limited"] += 1
        else:  # no exact command within the limit: min-max scaled down
            assert result.status == "rate_limited"
            free = minimax_steering(J, h, hdot, np.inf).beta_rate
            np.testing.assert_allclose(result.beta_rate, result.scale * free, atol=1e-9 * limit)
            seen["rate_limited"] += 1
        assert peak <= limit
    assert min(seen.values()) >= 20, seen


def test_torque_exact_to_round_off_and_avoidance_only_along_the_null_space():
    rng = np.random.default_rng(22)
    checked = 0
    for beta, alpha, h, hdot, limit, floor, gain in random_cases(rng, 400):
        J = rhombus_jacobian(beta, alpha)
        result = avoid(beta, alpha, h, hdot, limit, measure_floor=floor, barrier_gain_per_s=gain)
        if "rate_limited" in result.status:
            continue
        np.testing.assert_allclose(h * J @ result.beta_rate, hdot, atol=1e-12 * h * (1 + np.abs(result.beta_rate).max()))
        np.testing.assert_allclose(result.hdot_delivered, h * J @ result.beta_rate, rtol=1e-12, atol=1e-15 * h)
        # the difference from the plain min-max command lies in ker J, spanned by the null vector n
        shift = result.beta_rate - minimax_steering(J, h, hdot, np.inf).beta_rate
        n = np.linalg.svd(J)[2][3]
        np.testing.assert_allclose(shift, (shift @ n) * n, atol=1e-11 * (1 + np.abs(shift).max()))
        checked += 1
    assert checked > 200


def test_far_from_singular_sets_it_is_the_min_max_law():
    """floor 0 and m ~ 1: the barrier's right side is far below any reachable dm/dt."""
    rng = np.random.default_rng(23)
    for beta, alpha, h, hdot, *_ in random_cases(rng, 200, min_measure=0.5):
        barrier = avoid(beta, alpha, h, hdot, np.inf, measure_floor=0.0, barrier_gain_per_s=1e6)
        plain = minimax_steering(rhombus_jacobian(beta, alpha), h, hdot, np.inf)
        np.testing.assert_allclose(barrier.beta_rate, plain.beta_rate, rtol=1e-9, atol=1e-12 * np.abs(plain.beta_rate).max())


def test_rate_bounds_are_met_with_exact_torque_when_the_null_space_allows():
    """Asymmetric per-gimbal bounds: when the LP finds an exact command inside them, so does the law."""
    rng = np.random.default_rng(24)
    exact = 0
    for beta, alpha, h, hdot, limit, *_ in random_cases(rng, 300):
        J = rhombus_jacobian(beta, alpha)
        lo = -limit * rng.uniform(0.1, 1.0, 4)
        hi = limit * rng.uniform(0.1, 1.0, 4)
        result = avoid(beta, alpha, h, hdot, limit, measure_floor=0.0, barrier_gain_per_s=1e-9, rate_bounds=(lo, hi))
        assert np.all(result.beta_rate >= lo) and np.all(result.beta_rate <= hi)
        feasible = linprog(np.zeros(4), A_eq=J, b_eq=hdot / h, bounds=list(zip(lo, hi)), method="highs",
                           options=HIGHS).status == 0
        assert ("rate_limited" not in result.status) == feasible
        if feasible:
            np.testing.assert_allclose(h * J @ result.beta_rate, hdot, atol=1e-9 * np.linalg.norm(hdot))
            exact += 1
    assert exact > 50


@pytest.mark.parametrize("options, field", [
    ({}, "steering.column_derivative"),
    ({"column_derivative": np.zeros((3, 3))}, "steering.column_derivative"),
    ({"column_derivative": np.full((3, 4), np.nan)}, "steering.column_derivative"),
    ({"column_derivative": np.zeros((3, 4)), "measure_floor": -0.1}, "steering.measure_floor"),
    ({"column_derivative": np.zeros((3, 4)), "barrier_gain_per_s": 0.0}, "steering.barrier_gain_per_s"),
    ({"column_derivative": np.zeros((3, 4)), "rate_bounds": ([1, 1, 1, 1], [0, 0, 0, 0])}, "steering.rate_bounds"),
    ({"column_derivative": np.zeros((3, 4)), "preference_gain_per_s": -1.0}, "steering.preference_gain_per_s"),
    ({"column_derivative": np.zeros((3, 4)), "preference_rate_fraction": 1.5}, "steering.preference_rate_fraction"),
    ({"column_derivative": np.zeros((3, 4)), "peak_rate_so_far": math.nan}, "steering.peak_rate_so_far"),
    ({"column_derivative": np.zeros((3, 4)), "gimbal_angle": np.zeros(4), "preferred_gimbal_angles": np.zeros(3),
      "preferred_jacobian": np.zeros((3, 4))}, "steering.preferred_gimbal_angles"),
    ({"column_derivative": np.zeros((3, 4)), "gimbal_angle": np.zeros(4), "preferred_gimbal_angles": np.zeros(4),
      "preferred_jacobian": np.full((3, 4), np.inf)}, "steering.preferred_gimbal_angles"),
])
def test_bad_input_names_the_field(options, field):
    J = rhombus_jacobian(np.array([0.1, 0.2, 0.3, 0.4]), 0.9)
    with pytest.raises(InputError) as err:
        minimax_avoid_steering(J, 1.0, [1.0, 0.0, 0.0], 1.0, **options)
    assert err.value.field == field


# ---- the pull back to the start's zero-momentum family (module doc, eq. 4-5) -------------------

START = np.radians([45.0, -45.0, -45.0, 45.0])  # the rhombus's non-singular zero-momentum set
ALPHA = math.radians(54.7356)


def preferred(beta, start=START, alpha=ALPHA, **options):
    """The step inputs of the preference at gimbal angles beta for a run that started at `start`."""
    return {"gimbal_angle": beta, "preferred_gimbal_angles": start, "preferred_jacobian": rhombus_jacobian(start, alpha),
            "column_derivative": rhombus_column_derivative(beta, alpha)} | options


def expected_pull(beta, start=START, alpha=ALPHA):
    """-(p - (p . v0) v0) projected onto ker J(beta), p = sin(beta - beta0): eq. (4) with scipy's
    null spaces (v0 of J(beta0), v4 of J(beta)) instead of the law's SVD."""
    v0 = null_space(rhombus_jacobian(start, alpha))[:, 0]
    v4 = null_space(rhombus_jacobian(beta, alpha))[:, 0]
    p = np.sin(beta - start)
    return -((p - (p @ v0) * v0) @ v4) * v4


def test_at_rest_the_preference_is_the_descent_of_the_distance_to_the_start_family():
    """H' = 0 and the barrier off: the command is -k p_perp on ker J, or that direction cut to the
    rate budget nu beta'max; the family beta0 + s (1, -1, -1, 1) itself is not pulled along."""
    rng = np.random.default_rng(25)
    cut = 0
    for _ in range(200):
        beta = START + rng.normal(scale=0.4, size=4)
        if measure(beta, ALPHA) < 0.05:
            continue
        gain, limit = rng.uniform(0.1, 3.0), rng.uniform(0.2, 1.0)
        result = minimax_avoid_steering(rhombus_jacobian(beta, ALPHA), 20.0, np.zeros(3), limit, measure_floor=0.0,
                                        preference_gain_per_s=gain, preference_rate_fraction=0.1,
                                        **preferred(beta))
        wanted = gain * expected_pull(beta)
        budget = 0.1 * limit
        if np.abs(wanted).max() > budget:
            wanted *= budget / np.abs(wanted).max()
            cut += 1
        np.testing.assert_allclose(result.beta_rate, wanted, atol=1e-12)
        assert result.status == "ok"
    assert cut > 20
    along = START + 0.3 * np.array([1.0, -1.0, -1.0, 1.0])   # on the zero-momentum family
    result = minimax_avoid_steering(rhombus_jacobian(along, ALPHA), 20.0, np.zeros(3), 1.0, measure_floor=0.0,
                                    **preferred(along))
    np.testing.assert_allclose(result.beta_rate, 0.0, atol=1e-15)


def test_the_preference_keeps_the_torque_and_spends_only_the_rate_budget():
    """Exact torque, a shift from the min-max command along ker J only, and a step peak rate within
    max(f(t*), min(peak so far, beta'max), nu beta'max) (eq. 5), f(t*) from `minimax`."""
    rng = np.random.default_rng(26)
    moved = 0
    for _ in range(300):
        beta = rng.uniform(-np.pi, np.pi, 4)
        if measure(beta, ALPHA) < 0.3:
            continue
        h, limit = 20.0, rng.uniform(0.2, 1.0)
        hdot = rng.normal(size=3) * h * rng.uniform(0.0, 0.1)
        so_far = rng.uniform(0.0, 1.2) * limit
        J = rhombus_jacobian(beta, ALPHA)
        result = minimax_avoid_steering(J, h, hdot, limit, measure_floor=0.0, barrier_gain_per_s=1e6,
                                        peak_rate_so_far=so_far, **preferred(beta))
        if "rate_limited" in result.status:
            continue
        plain = minimax_steering(J, h, hdot, np.inf).beta_rate
        np.testing.assert_allclose(h * J @ result.beta_rate, hdot, atol=1e-12 * h * (1 + np.abs(result.beta_rate).max()))
        shift = result.beta_rate - plain
        v4 = null_space(J)[:, 0]
        np.testing.assert_allclose(shift, (shift @ v4) * v4, atol=1e-11 * (1 + np.abs(shift).max()))
        level = max(np.abs(plain).max(), min(so_far, limit), 0.1 * limit)
        assert np.abs(result.beta_rate).max() <= level * (1 + 1e-9)
        moved += np.abs(shift).max() > 1e-6 * limit
    assert moved > 100


def test_where_the_demand_sets_the_peak_it_is_the_min_max_law():
    """Peak so far 0, nu = 0: the budget is the min-max point itself (eq. 5), whatever the pull."""
    rng = np.random.default_rng(27)
    for beta, alpha, h, hdot, *_ in random_cases(rng, 200, min_measure=0.5):
        start = beta + rng.normal(scale=0.5, size=4)
        if measure(start, alpha) < 0.5:
            continue
        pulled = minimax_avoid_steering(rhombus_jacobian(beta, alpha), h, hdot, np.inf, measure_floor=0.0,
                                        barrier_gain_per_s=1e6, preference_rate_fraction=0.0, preference_gain_per_s=5.0,
                                        **preferred(beta, start, alpha))
        plain = minimax_steering(rhombus_jacobian(beta, alpha), h, hdot, np.inf)
        assert np.abs(pulled.beta_rate).max() == pytest.approx(np.abs(plain.beta_rate).max(), rel=1e-9)


def test_no_preference_from_a_start_near_a_singular_set():
    """A start with m <= m_floor (here beta = 0, rank 1) gives nothing to return to: the command is
    the one without the preference's inputs."""
    beta = np.array([0.3, -0.2, 0.5, 0.1])
    J = rhombus_jacobian(beta, ALPHA)
    for start in (np.zeros(4), START):
        with_start = minimax_avoid_steering(J, 20.0, np.zeros(3), 1.0, measure_floor=1.4,
                                            **preferred(beta, start))
        without = minimax_avoid_steering(J, 20.0, np.zeros(3), 1.0, measure_floor=1.4,
                                         column_derivative=rhombus_column_derivative(beta, ALPHA))
        np.testing.assert_array_equal(with_start.beta_rate, without.beta_rate)


# ---- random slews outside the study's seed (bench/steering_study.py, docs/theory/steering.md "Steering study") ---

OTHER_SEED, OTHER_SLEWS = 41, 5


@pytest.mark.slow
@pytest.mark.parametrize("slew", range(OTHER_SLEWS))
def test_random_slews_of_another_seed_keep_away_from_singular_sets(slew):
    """The first slews of seed 41 (the study's are seed 14), flown as the study flies them: the law
    keeps sqrt(det JJ') >= 1e-3 on each, within the rate limit, and ends on the target."""
    import importlib.util
    from pathlib import Path

    import testbed

    spec = importlib.util.spec_from_file_location(
        "steering_study", Path(__file__).resolve().parents[1] / "bench" / "steering_study.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    case = module.study_cases([slew], ["minimax_avoid"], seed=OTHER_SEED)[0]
    metrics = testbed.run(case.data).metrics
    assert metrics["min_singularity_measure"] >= 1e-3
    assert metrics["rate_limit_violations"] == 0
    assert metrics["final_attitude_error_deg"] <= 0.01
