"""Bad attitude-determination input is refused before the run: exit 2, one line naming the field."""

import pytest
import yaml

from testbed.cli import main
from testbed.scenario.shipped_files import SCENARIO_DIR

COVARIANCE = "[[1,0,0,0,0,0],[0,1,0,0,0,0],[0,0,1,0,0,0],[0,0,0,1,0,0],[0,0,0,0,1,0],[0,0,0,0,0,-1]]"
RAGGED = "[[1,0,0,0,0,0],[0,1,0,0,0,0],[0,0,1,0,0,0],[0,0,0,1,0,0],[0,0,0,0,1,0],[1]]"
ALLOCATOR = '''
import numpy as np
import testbed


@testbed.stage("allocator", "user.own_gyroscopic")
class OwnGyroscopic:
    """Adds w x H to the demand itself (design key internal_momentum) and says nothing of the law."""

    output = "body_torque"

    @classmethod
    def design(cls, params):
        return {"internal_momentum": "momentum"}

    def __init__(self, params, ctx):
        pass

    def allocate(self, t, demand, estimate, actuators):
        return {"body_torque": np.asarray(demand["torque"], float)}
'''


@pytest.mark.parametrize("assignment, field", [
    ("pipeline.sensor.gyro.angle_random_walk_rad_sqrt_s=0", "pipeline.sensor.gyro.angle_random_walk_rad_sqrt_s"),
    ("pipeline.sensor.gyro.rate_random_walk_rad_s_sqrt_s=-1e-7", "pipeline.sensor.gyro.rate_random_walk_rad_s_sqrt_s"),
    ("pipeline.sensor.star_tracker.about_boresight_noise_arcsec=0",
     "pipeline.sensor.star_tracker.about_boresight_noise_arcsec"),
    ("pipeline.sensor.star_tracker.sample_period_s=0.15", "pipeline.sensor.star_tracker.sample_period_s"),
    ("pipeline.sensor.star_tracker.boresight=[0,0,0]", "pipeline.sensor.star_tracker.boresight"),
    ("pipeline.sensor.star_tracker.outages_s=[[30,10]]", "pipeline.sensor.star_tracker.outages_s[0]"),
    ("pipeline.sensor.star_tracker.sun_exclusion_deg=30", "pipeline.sensor.star_tracker.sun_exclusion_deg"),
    ("pipeline.sensor.star_tracker.moon_exclusion_deg=10", "pipeline.sensor.star_tracker.moon_exclusion_deg"),
    ("pipeline.sensor.star_tracker.moon_exclusion_deg=180", "pipeline.sensor.star_tracker.moon_exclusion_deg"),
    (f"pipeline.estimator.initial_covariance={COVARIANCE}", "pipeline.estimator.initial_covariance"),
    # a ragged P0 (five rows of six, one of one) raised numpy's inhomogeneous-shape ValueError
    (f"pipeline.estimator.initial_covariance={RAGGED}", "pipeline.estimator.initial_covariance[5]"),
    # floating-point edges: each under- or overflowed at build or at t = 0 as a numpy exception
    ("pipeline.sensor.star_tracker.cross_boresight_noise_arcsec=1e-300",
     "pipeline.sensor.star_tracker.cross_boresight_noise_arcsec"),
    ("pipeline.sensor.gyro.angle_random_walk_rad_sqrt_s=1e200", "pipeline.sensor.gyro.angle_random_walk_rad_sqrt_s"),
    ("pipeline.sensor.gyro.rate_random_walk_rad_s_sqrt_s=1e200", "pipeline.sensor.gyro.rate_random_walk_rad_s_sqrt_s"),
    ("pipeline.sensor.gyro.quantisation_rad=1e-320", "pipeline.sensor.gyro.quantisation_rad"),
    ("pipeline.sensor.gyro.initial_bias_rad_s=[1e300, 0, 0]", "pipeline.sensor.gyro.initial_bias_rad_s[0]"),
])
def test_refused_naming_the_field(assignment, field, tmp_path, monkeypatch, capfd):
    monkeypatch.chdir(tmp_path)
    code = main(["run", "attitude_outage_mekf", "--set", assignment])
    err = capfd.readouterr().err
    assert code == 2
    assert err.startswith(f"error: {field}:") and len(err.strip().splitlines()) == 1, err
    assert list(tmp_path.iterdir()) == []           # nothing written


def _scenario(tmp_path, **pipeline):
    data = yaml.safe_load((SCENARIO_DIR / "attitude_outage_mekf.yaml").read_text())
    data["pipeline"] |= pipeline
    path = tmp_path / "in" / "s.yaml"
    path.parent.mkdir(exist_ok=True)
    path.write_text(yaml.safe_dump(data))
    return path


def test_mekf_without_a_tracker_and_gyro_is_refused(tmp_path, monkeypatch, capfd):
    path = _scenario(tmp_path, sensor={"type": "ideal_attitude"})
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(path)]) == 2
    assert capfd.readouterr().err.startswith("error: pipeline.estimator.type:")


def test_a_law_and_an_allocator_that_both_compensate_are_refused(tmp_path, monkeypatch, capfd):
    (tmp_path / "in").mkdir()
    (tmp_path / "in" / "own.py").write_text(ALLOCATOR)
    path = _scenario(tmp_path, law={"type": "quaternion_feedback"}, allocator={"type": "user.own_gyroscopic"})
    text = yaml.safe_load(path.read_text())
    path.write_text(yaml.safe_dump(text | {"plugins": ["own.py"]}))
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(path)]) == 2
    err = capfd.readouterr().err
    assert err.startswith("error: pipeline.allocator.type:") and "internal_momentum" in err, err


@pytest.mark.parametrize("end", [0, 1])
def test_the_sensor_bounds_hold_the_filter_in_normal_doubles(end):
    """At both ends of every bounded gyro and tracker parameter, the package and the MEKF build and
    filter the first samples with every floating-point error raising (what the bounds promise)."""
    import numpy as np

    import testbed
    from testbed.sensors.gyro_package import GyroPackageParams
    from testbed.sensors.star_tracker import NOISE_RANGE_ARCSEC

    def edge(name):
        meta = GyroPackageParams.__dataclass_fields__[name].metadata
        return (meta["ge"], meta["le"])[end]

    noise = NOISE_RANGE_ARCSEC[end]
    overrides = [f"pipeline.sensor.gyro.{name}={edge(name)}" for name in
                 ("angle_random_walk_rad_sqrt_s", "rate_random_walk_rad_s_sqrt_s")]
    overrides += [f"pipeline.sensor.gyro.initial_bias_rad_s=[{edge('initial_bias_rad_s')}, 0, 0]",
                  f"pipeline.sensor.gyro.scale_factor_ppm=[{edge('scale_factor_ppm')}, 0, 0]",
                  f"pipeline.sensor.gyro.misalignment_rad=[{edge('misalignment_rad')}, 0, 0, 0, 0, 0]",
                  f"pipeline.sensor.gyro.quantisation_rad={(1e-12, 1.0)[end]}",
                  f"pipeline.sensor.star_tracker.cross_boresight_noise_arcsec={noise}",
                  f"pipeline.sensor.star_tracker.about_boresight_noise_arcsec={noise}", "sim.duration_s=1"]
    with np.errstate(all="raise"):
        result = testbed.run("attitude_hold_mekf", overrides=overrides)
    assert result.status == "ok", result.error
