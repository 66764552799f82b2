"""The gyro package and the star tracker against their error models' statistics."""

import numpy as np
import pytest

from testbed.math.quaternion import quat_conj, quat_from_axis_angle, quat_mul, rotation_vector
from testbed.pipeline import StageContext
from testbed.scenario import schema
from testbed.sensors.gyro_package import GyroPackage, GyroPackageParams
from testbed.sensors.suite import StarTrackerGyro, StarTrackerGyroParams

ARCSEC = np.pi / (180.0 * 3600.0)


class _Body:
    """Stands in for a plant: the sensors read quat() and omega()."""

    def __init__(self, quat=(1.0, 0.0, 0.0, 0.0), omega=(0.0, 0.0, 0.0)):
        self.q, self.w = np.asarray(quat, float), np.asarray(omega, float)

    def quat(self):
        return self.q

    def omega(self):
        return self.w


def _gyro(period=0.1, **params):
    values = {"angle_random_walk_rad_sqrt_s": 1e-3, "rate_random_walk_rad_s_sqrt_s": 1e-4} | params
    return GyroPackage(schema.load(GyroPackageParams, values, "gyro"), period)


def _suite(tracker=None, gyro=None, control=0.1, estimator=None):
    data = {"star_tracker": {"cross_boresight_noise_arcsec": 5.0, "about_boresight_noise_arcsec": 40.0} | (tracker or {}),
            "gyro": {"angle_random_walk_rad_sqrt_s": 1e-5, "rate_random_walk_rad_s_sqrt_s": 1e-8} | (gyro or {})}
    params = schema.load(StarTrackerGyroParams, data, "pipeline.sensor")
    ctx = StageContext(dt=0.01, control_period=control, sample_period=estimator, inertia=np.eye(3))
    return StarTrackerGyro(params, ctx)


def _allan_variance(rates, m):
    """Non-overlapping Allan variance at τ = m Δt (IEEE Std 952-1997, annex C), per axis."""
    clusters = rates[: len(rates) // m * m].reshape(-1, m, rates.shape[1]).mean(axis=1)
    return 0.5 * np.mean(np.diff(clusters, axis=0) ** 2, axis=0)


def test_allan_variance_follows_the_angle_and_rate_random_walks():
    # IEEE Std 952 (eq. C.12): σ_A²(τ) = σ_v²/τ + σ_u² τ / 3 for ARW σ_v and RRW σ_u. Exact for the
    # sampled model at every τ = m Δt; the estimate's relative error is about 1/sqrt(clusters).
    arw, rrw, dt = 1e-3, 1e-4, 0.1
    gyro = _gyro(dt, angle_random_walk_rad_sqrt_s=arw, rate_random_walk_rad_s_sqrt_s=rrw, seed=3)
    rates = np.array([gyro.sample(np.zeros(3)) for _ in range(60000)])
    # 60000, 6000 and 350 clusters: relative errors about sqrt(2 / clusters) = 0.6 %, 1.8 %, 7.5 %
    for m, tolerance in ((1, 0.02), (10, 0.05), (170, 0.2)):
        tau = m * dt
        expected = arw**2 / tau + rrw**2 * tau / 3
        assert _allan_variance(rates, m) == pytest.approx(np.full(3, expected), rel=tolerance), m


def test_scale_factor_misalignment_and_bias_enter_the_mean_rate():
    dt, omega = 0.1, np.array([0.02, -0.01, 0.03])
    gyro = _gyro(dt, angle_random_walk_rad_sqrt_s=1e-9, rate_random_walk_rad_s_sqrt_s=1e-12,
                 initial_bias_rad_s=[1e-4, 2e-4, -3e-4], scale_factor_ppm=[1000, -2000, 500],
                 misalignment_rad=[1e-3, 0, 0, -2e-3, 0, 5e-4])
    rate = gyro.sample(omega * dt)
    matrix = np.array([[1.001, 1e-3, 0.0], [0.0, 0.998, -2e-3], [0.0, 5e-4, 1.0005]])
    # noise 1e-9 / sqrt(0.1) = 3e-9 rad/s against rates of 1e-2: well-conditioned, pinned at 1e-7
    assert rate == pytest.approx(matrix @ omega + [1e-4, 2e-4, -3e-4], abs=1e-7)


def test_quantised_increments_lose_no_angle():
    dt, step = 0.1, 1e-4
    gyro = _gyro(dt, angle_random_walk_rad_sqrt_s=1e-9, rate_random_walk_rad_s_sqrt_s=1e-12, quantisation_rad=step)
    omega = np.array([1.234e-3, -7.7e-4, 3.3e-5])   # not a multiple of step / dt
    rates = np.array([gyro.sample(omega * dt) for _ in range(1000)])
    counts = rates * dt / step
    assert counts == pytest.approx(np.round(counts), abs=1e-6)   # each output a whole number of steps
    # the summed angle lags the true one by less than one step (plus the 3e-9 rad/s noise x 100 s)
    assert np.all(np.abs(rates.sum(axis=0) * dt - omega * 100.0) < step)


def test_star_tracker_noise_across_and_about_a_tilted_boresight():
    boresight = np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    sensor = _suite({"boresight": [2.0, 2.0, 0.0], "x_axis": [0, 0, 1], "seed": 4})
    body = _Body(quat_from_axis_angle(np.array([0.0, 0.6, 0.8]), 0.7))
    errors = []
    for k in range(8000):
        out = sensor.measure(0.1 * k, body)
        errors.append(rotation_vector(quat_mul(quat_conj(body.q), out["tracker_quat"])))
    errors = np.array(errors)
    about = errors @ boresight
    across = errors @ np.cross(boresight, [0.0, 0.0, 1.0]), errors @ np.array([0.0, 0.0, 1.0])
    # sample std of 8000 draws: relative standard error 1/sqrt(2 n) = 0.8 %
    assert np.std(about) == pytest.approx(40 * ARCSEC, rel=0.03)
    for part in across:
        assert np.std(part) == pytest.approx(5 * ARCSEC, rel=0.03)


def test_star_tracker_rate_latency_and_outages():
    sensor = _suite({"sample_period_s": 0.3, "latency_s": 0.2, "outages_s": [[0.55, 1.25]]})
    news, stamps, shown = [], [], []
    for k in range(16):
        t = 0.1 * k
        out = sensor.measure(t, _Body(quat_from_axis_angle(np.array([0.0, 0.0, 1.0]), 0.01 * k)))
        news.append(out["tracker_new"][0])
        stamps.append(out["tracker_stamp"][0])
        shown.append(2 * np.arctan2(out["tracker_quat"][3], out["tracker_quat"][0]) / 0.01)
    # samples every 3 periods, none in [0.55, 1.25): at 0, 0.3 and 1.5 s (0.6, 0.9 and 1.2 s dropped)
    assert [k for k, new in enumerate(news) if new] == [0, 3, 15]
    assert stamps[3] == pytest.approx(0.1)                      # 0.3 s less the 0.2 s latency
    assert shown[3] == pytest.approx(1.0, abs=0.1)              # the attitude of tick 1 (noise 5-40 arcsec)
    assert shown[0] == pytest.approx(0.0, abs=0.1)              # before the latency: the first image
