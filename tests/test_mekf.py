"""The MEKF against independent numbers: Farrenkopf's analytic steady state, the bias inside its
3σ bound, the NEES against the χ² band, the covariance growth of an outage."""

import dataclasses

import numpy as np
import pytest
import scipy.linalg
import scipy.stats

import testbed
from testbed import pipeline
from testbed.math.quaternion import quat_from_axis_angle
from testbed.mekf.metrics import attitude_errors
from testbed.mekf.stage import MekfEstimator, MekfParams
from testbed.pipeline import StageContext
from testbed.scenario import schema
from testbed.sensors.suite import StarTrackerGyro, StarTrackerGyroParams

ARCSEC = np.pi / (180.0 * 3600.0)
ARW, RRW, DT = 4.4e-5, 1.0e-7, 0.1           # the shipped scenarios' gyro package and tracker period
SIGMA = np.array([5.0, 5.0, 40.0]) * ARCSEC  # tracker noise about body x, y (across) and z (boresight)


def farrenkopf_variances(arw, rrw, sigma, dt):
    """Farrenkopf's steady-state attitude variances (pre-update, post-update) of the single-axis
    gyro + attitude-sensor Kalman filter (Farrenkopf 1978, JGC 1(4); the discrete form of
    Markley & Reynolds 2000, "Analytic steady-state accuracy of a spacecraft attitude estimator",
    JGCD 23(6)), in their parameters S_v = σ_v Δt^½ / σ_n and S_u = σ_u Δt^{3/2} / σ_n.

    The closed form comes from the spectral factorisation of the measurement's second difference,
    whose autocovariances are (σ_n² units) R0 = 6 + 2 S_v² + 2 S_u²/3, R1 = -4 - S_v² + S_u²/6,
    R2 = 1: x² + R1 x + R0 - 2 = 0 gives x₁, x₂, and the innovation variance is
    λ = Π (x_i + (x_i² - 4)^½) / 2; then p⁻ = σ_n² (λ - 1), p⁺ = σ_n² (1 - 1/λ)
    (docs/theory/attitude_determination.md)."""
    sv, su = arw * np.sqrt(dt) / sigma, rrw * dt**1.5 / sigma
    r0, r1 = 6 + 2 * sv**2 + 2 * su**2 / 3, -4 - sv**2 + su**2 / 6
    root = np.sqrt(complex(r1**2 - 4 * (r0 - 2)))
    lam = 1.0
    for x in ((-r1 + root) / 2, (-r1 - root) / 2):
        lam *= (x + np.sqrt(x * x - 4)) / 2
    lam = lam.real
    return sigma**2 * (lam - 1), sigma**2 * (1 - 1 / lam)


def test_farrenkopf_closed_form_is_the_riccati_solution():
    # a second method: SciPy's discrete algebraic Riccati equation of the same single-axis model
    for sigma in SIGMA[1:]:
        phi = np.array([[1.0, -DT], [0.0, 1.0]])
        q = np.array([[ARW**2 * DT + RRW**2 * DT**3 / 3, -RRW**2 * DT**2 / 2], [-RRW**2 * DT**2 / 2, RRW**2 * DT]])
        prior = scipy.linalg.solve_discrete_are(phi.T, np.array([[1.0], [0.0]]), q, np.array([[sigma**2]]))
        pre, post = farrenkopf_variances(ARW, RRW, sigma, DT)
        assert pre == pytest.approx(prior[0, 0], rel=1e-6)   # two exact solutions: round-off apart
        assert post == pytest.approx(prior[0, 0] * sigma**2 / (prior[0, 0] + sigma**2), rel=1e-6)


@pytest.fixture(scope="module")
def hold():
    """attitude_hold_mekf, 300 s of its 600 (the filter settled after 100 s)."""
    return testbed.run("attitude_hold_mekf", overrides=["sim.duration_s=300"])


def _settled_errors(result, settle=100.0):
    t, estimate = result.trace["estimator/quat"]
    truth = result.trace["truth/quat"][1][: len(t)]   # the truth has one more row: the final state
    rows = (t >= settle) & np.all(np.isfinite(estimate), axis=1)
    return rows, attitude_errors(truth[rows], estimate[rows])


@pytest.mark.slow
def test_steady_state_error_is_farrenkopfs(hold):
    assert hold.status == "ok"
    rows, errors = _settled_errors(hold)
    post = np.sqrt([farrenkopf_variances(ARW, RRW, sigma, DT)[1] for sigma in SIGMA])   # 3.29, 3.29, 10.6 arcsec
    # the 10 %: the sample sigma of 2000 correlated samples (about 4 % standard error about z)
    assert np.std(errors, axis=0) == pytest.approx(post, rel=0.10)
    # the filter's own sigma is the Riccati solution itself: well-conditioned, 1 %
    _, bound = hold.trace["estimator/attitude_sigma3"]
    assert bound[rows][-1] / 3 == pytest.approx(post, rel=0.01)


@pytest.mark.slow
def test_bias_estimate_stays_within_its_3_sigma(hold):
    t, bias = hold.trace["estimator/bias"]
    _, truth = hold.trace["sensor/gyro_bias"]
    _, bound = hold.trace["estimator/bias_sigma3"]
    rows = (t >= 100.0) & np.all(np.isfinite(bias), axis=1)
    inside = np.all(np.abs(bias[rows] - truth[rows]) <= bound[rows], axis=1)
    assert np.mean(inside) >= 0.99
    # converged: from a 50 deg/h prior to a sigma below 1 deg/h (the biases are 20, -10, 4 deg/h)
    assert np.all(bound[rows][-1] / 3 < np.radians(1.0) / 3600.0)


@pytest.mark.slow
def test_nees_over_seeds_lies_in_the_chi_square_band():
    # the suite's 10 seeds of the 50-seed campaign: 10 x mean NEES ~ chi2(3 x 10) for a consistent filter
    seeds = 10
    values = [testbed.run("attitude_nees_campaign",
                          overrides=[f"pipeline.sensor.star_tracker.seed={100 + k}",
                                     f"pipeline.sensor.gyro.seed={200 + k}", "sim.duration_s=80",
                                     "pipeline.estimator.settle_s=40"]).metrics["final_attitude_nees"]
              for k in range(seeds)]
    low, high = scipy.stats.chi2.ppf([0.025, 0.975], 3 * seeds) / seeds   # [1.68, 4.70]
    assert low <= np.mean(values) <= high


@pytest.mark.slow
def test_outage_covariance_grows_as_the_gyro_model_predicts_and_recovers():
    result = testbed.run("attitude_outage_mekf", overrides=["sim.duration_s=300"])
    t, flat = result.trace["estimator/covariance"]
    keep = np.all(np.isfinite(flat), axis=1)
    t, p = t[keep], flat[keep].reshape(-1, 6, 6)
    before, last = np.searchsorted(t, 199.95) - 1, np.searchsorted(t, 259.95) - 1   # 199.9 s and 259.9 s
    elapsed = t[last] - t[before]
    assert elapsed == pytest.approx(60.0)
    start = p[before]
    for axis in range(3):
        grown = (start[axis, axis] - 2 * elapsed * start[axis, axis + 3] + elapsed**2 * start[axis + 3, axis + 3]
                 + ARW**2 * elapsed + RRW**2 * elapsed**3 / 3)
        # a linear propagation at a rate of ~1e-4 rad/s (the gyro noise) instead of 0: well-conditioned, 0.1 %
        assert p[last][axis, axis] == pytest.approx(grown, rel=1e-3)
    # recovery: the tracker returns at 260 s; within 5 s every axis's sigma is back within 10 % of before
    sigma = np.sqrt(np.diagonal(p, axis1=1, axis2=2)[:, :3])
    back = t[np.argmax((t > 260.0) & np.all(sigma <= 1.1 * sigma[before], axis=1))]
    assert back - 260.0 <= 5.0
    rows, errors = _settled_errors(result, 265.0)
    # and the error inside 3 sigma again: each axis 99.73 %, all three 99.2 % of 350 correlated samples
    assert np.mean(np.all(np.abs(errors) <= 3 * sigma[t >= 265.0], axis=1)) >= 0.97


class _Turning:
    """Stands in for a plant turning at a constant body rate about z from the identity."""

    def __init__(self, rate):
        self.rate, self.t = rate, 0.0

    def quat(self):
        return quat_from_axis_angle(np.array([0.0, 0.0, 1.0]), self.rate * self.t)

    def omega(self):
        return np.array([0.0, 0.0, self.rate])


def test_a_late_tracker_sample_is_filtered_at_its_own_time():
    # 0.5 deg/s with a 0.2 s latency: a filter that took the sample as current would lag 0.1 deg
    # (360 arcsec) about z. Filtered at the sample's time and carried forward over L on the gyro,
    # the report's error is Farrenkopf's p⁺ plus the gyro's angle noise over L, σ_v² L
    rate = np.radians(0.5)
    sensor_params = schema.load(StarTrackerGyroParams, {
        "star_tracker": {"cross_boresight_noise_arcsec": 5, "about_boresight_noise_arcsec": 40, "latency_s": 0.2},
        "gyro": {"angle_random_walk_rad_sqrt_s": ARW, "rate_random_walk_rad_s_sqrt_s": RRW}}, "pipeline.sensor")
    base = StageContext(dt=0.1, control_period=0.1, inertia=np.eye(3), initial=testbed.load("attitude_outage_mekf").initial)
    infos = {"sensor": pipeline.StageInfo("star_tracker_gyro", StarTrackerGyro.design(sensor_params))}
    ctx = dataclasses.replace(base, stages=infos)
    sensor = StarTrackerGyro(sensor_params, ctx)
    estimator = MekfEstimator(schema.load(MekfParams, {"initial_attitude_sigma_deg": 0.1}, "pipeline.estimator"), ctx)
    body, errors, bounds = _Turning(rate), [], []
    for k in range(3000):
        body.t = 0.1 * k
        out = estimator.estimate(body.t, sensor.measure(body.t, body), {})
        if body.t >= 100:
            errors.append(attitude_errors(body.quat()[None], out["quat"][None])[0])
            bounds.append(out["attitude_sigma3"] / 3)
    errors, bounds = np.array(errors), np.array(bounds)
    sigma = np.sqrt([farrenkopf_variances(ARW, RRW, s, DT)[1] + ARW**2 * 0.2 for s in SIGMA])  # 5.2, 5.2, 11.3"
    # 2000 samples correlated over ~1 / S_v = 14 samples about z: the mean's standard error ~ 1 arcsec
    assert np.all(np.abs(np.mean(errors, axis=0)) < 3 * sigma / np.sqrt(2000 / 14))
    # the sample sigma (about 2 % standard error across, 4 % about z) and the filter's own (exact, 1 %)
    assert np.std(errors, axis=0) == pytest.approx(sigma, rel=0.1)
    assert bounds[-1] == pytest.approx(sigma, rel=0.01)


def test_coasting_past_the_error_models_bound_ends_the_run_when_the_gyro_model_says():
    """Issue 37: a tracker out from 200 s for good and a gyro ten times noisier (ARW 4.4e-4): the
    filter coasts; the run ends (method_failed) when an axis's attitude 3-sigma passes
    sqrt(2 sigma_m). Independent number: the time the validation-5 growth law, from the filter's
    P at the outage's start, reaches that bound (well conditioned: within two gyro samples)."""
    arw = 10 * ARW
    result = testbed.run("attitude_outage_mekf", overrides=[
        "sim.duration_s=600", f"pipeline.sensor.gyro.angle_random_walk_rad_sqrt_s={arw}",
        "pipeline.sensor.star_tracker.outages_s=[[200, 1000]]"])
    assert result.status == "method_failed" and "no star tracker fix for" in result.error, result.error
    t, flat = result.trace["estimator/covariance"]
    start = flat[np.searchsorted(t, 199.95) - 1].reshape(6, 6)   # the last update, 199.9 s
    bound = np.sqrt(2.0 * np.radians(np.array([5.0, 5.0, 40.0]) / 3600.0))   # boresight along body z
    elapsed = np.linspace(0.0, 400.0, 400_001)
    first = []
    for axis in range(3):
        grown = (start[axis, axis] - 2 * elapsed * start[axis, axis + 3] + elapsed**2 * start[axis + 3, axis + 3]
                 + arw**2 * elapsed + RRW**2 * elapsed**3 / 3)
        first.append(elapsed[np.argmax(9.0 * grown > bound[axis] ** 2)])
    assert result.sim_s - 199.9 == pytest.approx(min(first), abs=2 * DT)
    ok = testbed.run("attitude_outage_mekf", overrides=["sim.duration_s=300"])   # the shipped 60 s: well inside
    assert ok.status == "ok"
