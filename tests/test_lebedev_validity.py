"""Issue 37: Lebedev's closed-loop observer (eq. 4.6) leaving its validity ends the run with that
reason (status method_failed), not with a NumPy overflow (testbed/lebedev/validity.py).

Independent numbers: the design poles (the growth rate at the operating point is their largest
real part), the error Jacobian written out by hand from eq. 4.2 (A + dF/dx at the estimate), the
count of intervals a constant growth rate needs to reach one e-fold, and the time the same run
overflowed at before the test (165.95 s)."""

import math

import numpy as np
import pytest

from testbed.lebedev import validity
from testbed.lebedev.observer import LebedevObserver, lebedev_matrices
from testbed.lebedev.validity import ErrorGrowth, error_growth_rate, is_hurwitz
from testbed.pipeline import MethodFailed
from testbed.runner import run_scenario
from testbed.scenario.loading import load_scenario

# the flagship campaign's bus, gyro and design momentum (scenarios/lebedev_spinup_campaign.yaml)
MOMENTS = np.array([1239.575, 6894.557, 7084.538])
OMEGA = math.radians(1.0)
AXIS = np.ones(3) / math.sqrt(3.0)
H_DESIGN = np.array([0.0, 0.0, -123.918])
# a dispersed start the method does not recover from (w_y(0) = 0.4 deg/s, docs/campaigns.md);
# before the validity test it overflowed in the observer at t = 165.95 s
DIVERGING = ["initial.omega_deg_s=[0.25, 0.4, 0]", "sim.duration_s=200"]
OVERFLOW_S = 165.95


def _observer():
    return LebedevObserver(MOMENTS, OMEGA, AXIS, [-0.1, -0.1, -0.1], design_momentum=H_DESIGN)


def test_growth_rate_at_the_operating_point_is_the_design_pole():
    """At w_hat = Omega e_z the error matrix is A + I^-1 [H x] - l C, whose poles were placed at a
    triple -0.1 1/s; a triple pole moves by the cube root of round-off, so 1e-4 (measured 6.8e-6)."""
    obs = _observer()
    rate = error_growth_rate(MOMENTS, [0.0, 0.0, OMEGA], H_DESIGN, obs.l_closed, AXIS)
    assert rate == pytest.approx(-0.1, abs=1e-4)


def test_growth_rate_is_the_error_jacobian_of_eq_4_2_at_the_estimate():
    """Off the operating point the matrix gains dF/dx at z (F of eq. 4.2, written out here) and,
    for the rigid body, nothing else: eigenvalues to round-off (well conditioned away from z = 0)."""
    obs = LebedevObserver(MOMENTS, OMEGA, AXIS, [-0.1, -0.1, -0.1])
    a, A = lebedev_matrices(MOMENTS, OMEGA)
    rng = np.random.default_rng(37)
    for _ in range(5):
        z = rng.normal(size=3) * math.radians(2.0)
        dF = np.array([[0.0, a[0] * z[2], a[0] * z[1]], [a[1] * z[2], 0.0, a[1] * z[0]],
                       [a[2] * z[1], a[2] * z[0], 0.0]])
        expected = np.linalg.eigvals(A + dF - np.outer(obs.l, AXIS)).real.max()
        got = error_growth_rate(MOMENTS, z + [0.0, 0.0, OMEGA], np.zeros(3), obs.l, AXIS)
        assert got == pytest.approx(expected, rel=1e-9, abs=1e-12)


def test_a_constant_growth_is_declared_after_one_e_fold():
    """A held estimate where the error grows at sigma: the test fires at the first interval where
    sigma t reaches GROWTH_LIMIT, never at the operating point, and names the criterion."""
    obs = _observer()
    away = np.array([0.0, math.radians(-3.0), OMEGA + math.radians(3.0)])
    sigma = error_growth_rate(MOMENTS, away, H_DESIGN, obs.l_closed, AXIS)
    assert sigma > 0.05
    growth, h = ErrorGrowth(MOMENTS, OMEGA, H_DESIGN, obs.l_closed, AXIS), 0.05
    for k in range(10_000):
        growth.advance(k * h, h, [0.0, 0.0, OMEGA])
    assert growth.log_growth == 0.0
    needed = math.ceil(validity.GROWTH_LIMIT / (sigma * h))
    for k in range(1, needed):
        growth.advance(k * h, h, away)
    with pytest.raises(MethodFailed, match=r"the observer diverged: .* unstable since t = 0 s"):
        growth.advance(needed * h, h, away)


def test_a_diverging_flagship_case_ends_named_before_the_overflow():
    """The campaign's w_y(0) = 0.4 deg/s start: status method_failed, the reason named, before the
    time it overflowed at; with the test switched off the same run still ends in the overflow,
    now said to be the observer's divergence, not a bare FloatingPointError."""
    run = run_scenario(load_scenario("lebedev_spinup_campaign", DIVERGING), None)
    assert run.status == "method_failed" and not run.passed
    assert "estimator 'lebedev' left its validity" in run.error and "the observer diverged" in run.error
    assert 150.0 < run.sim_s < OVERFLOW_S - 1.0   # measured 159.3 s: after the loop closes, before it blew up
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(validity, "GROWTH_LIMIT", math.inf)
        unchecked = run_scenario(load_scenario("lebedev_spinup_campaign", DIVERGING), None)
    assert unchecked.status == "method_failed" and "its state overflowed" in unchecked.error
    assert unchecked.sim_s == pytest.approx(OVERFLOW_S, abs=0.1)


def test_routh_hurwitz_agrees_with_the_eigenvalues():
    """The quick test `advance` makes before any eigenvalue: the same verdict as the largest real
    part of the eigenvalues on random matrices, both signs represented."""
    rng = np.random.default_rng(7)
    verdicts = []
    for _ in range(2000):
        matrix = rng.normal(size=(3, 3)) - rng.uniform(0.0, 2.0) * np.eye(3)
        verdicts.append(is_hurwitz(matrix))
        assert verdicts[-1] == (np.linalg.eigvals(matrix).real.max() < 0.0)
    assert 200 < sum(verdicts) < 1800
