"""The single-axis rate gyro: y = p . w + b + noise, quantised, held between its samples."""

import numpy as np
import pytest

from testbed.scenario import schema
from testbed.errors import InputError
from testbed.pipeline import StageContext
from testbed.stages.rate_gyro import RateGyro, RateGyroParams

AXIS = [0.6, 0.0, 0.8]


class _Body:
    """Stands in for a plant: the gyro reads only omega()."""

    def __init__(self, omega):
        self.w = np.asarray(omega, float)

    def omega(self):
        return self.w


def _gyro(dt=0.01, control=0.1, **params):
    p = schema.load(RateGyroParams, {"axis": AXIS, **params}, "pipeline.sensor")
    ctx = StageContext(dt=dt, control_period=control, inertia=np.eye(3))
    return RateGyro(p, ctx)


def test_reads_the_projection_plus_bias_and_quantises():
    w = np.array([0.01, -0.02, 0.03])
    gyro = _gyro(bias_rad_s=1e-4, quantisation_rad_s=1e-3)
    y = gyro.measure(0.0, _Body(w))["y"][0]
    exact = 0.6 * 0.01 + 0.8 * 0.03 + 1e-4  # 0.0301
    assert y == pytest.approx(0.030, abs=1e-15)           # nearest multiple of 1e-3
    assert abs(y - exact) <= 0.5e-3


def test_holds_its_sample_between_sample_instants():
    gyro = _gyro(sample_period_s=0.3)
    body = _Body([0.0, 0.0, 1.0])
    stamps, values = [], []
    for k in range(7):
        body.w = np.array([0.0, 0.0, float(k)])
        out = gyro.measure(0.1 * k, body)
        stamps.append(out["stamp"][0])
        values.append(out["y"][0])
    assert stamps == pytest.approx([0.0, 0.0, 0.0, 0.3, 0.3, 0.3, 0.6])
    assert values == pytest.approx([0.0, 0.0, 0.0, 2.4, 2.4, 2.4, 4.8])


def test_noise_has_the_stated_sigma_and_is_reproducible():
    body = _Body([0.0, 0.0, 0.0])
    samples = [_gyro(noise_sigma_rad_s=2e-3, seed=5).measure(0.0, body) for _ in range(2)]
    assert samples[0]["y"][0] == samples[1]["y"][0]
    gyro = _gyro(noise_sigma_rad_s=2e-3, seed=5)
    y = np.array([gyro.measure(0.1 * k, body)["y"][0] for k in range(20000)])
    # sample std of 20000 normal draws: relative standard error 1/sqrt(2 n) = 0.5 %
    assert np.std(y) == pytest.approx(2e-3, rel=0.03)
    assert abs(np.mean(y)) < 5 * 2e-3 / np.sqrt(len(y))


@pytest.mark.parametrize("params, field, words", [
    ({"axis": [1.0, 1.0, 0.0]}, "pipeline.sensor.axis", "unit vector"),
    ({"axis": [0.0, 0.0, 0.0]}, "pipeline.sensor.axis", "zero vector"),
    ({"noise_sigma_rad_s": -1.0}, "pipeline.sensor.noise_sigma_rad_s", ">= 0"),
])
def test_bad_parameters_are_refused(params, field, words):
    with pytest.raises(InputError) as info:
        schema.load(RateGyroParams, {"axis": AXIS, **params}, "pipeline.sensor")
    assert info.value.field == field and words in info.value.reason


def test_sample_period_must_be_a_multiple_of_the_physics_step():
    with pytest.raises(InputError, match="physics step"):
        _gyro(dt=0.01, control=0.1, sample_period_s=0.015)
