"""Fit checks before the run: an orbit or an environment that cannot hold is exit 2 with one
line naming the field (`testbed check FILE`), before anything runs."""

from __future__ import annotations

import pytest
import yaml

from testbed.cli import main

BASE = {"name": "fit", "model": {"system": "satellite"}, "sim": {"duration_s": 10, "dt_s": 0.1},
        "orbit": {"altitude_km": 500}}


def _with(**blocks):
    data = {key: (dict(value) if isinstance(value, dict) else value) for key, value in BASE.items()}
    for key, value in blocks.items():
        if value is None:
            data.pop(key)
        else:
            data[key] = value
    return data


@pytest.mark.parametrize(("blocks", "field"), [
    ({"orbit": {"altitude_km": -100}}, "orbit.altitude_km"),
    ({"orbit": {"semi_major_axis_km": 6000}}, "orbit.semi_major_axis_km"),                 # inside the Earth
    ({"environment": {"drag": {}}, "orbit": {"altitude_km": 1500}}, "environment.drag.atmosphere"),  # above its table
    ({"environment": {"drag": {}}, "orbit": {"semi_major_axis_km": 6800, "eccentricity": 0.0555}},
     "environment.drag.atmosphere"),                                                        # perigee at 44 km
    ({"orbit": {"tle": ["1 25544U 98067A   24001.5", "2 25544  51.6416"]}}, "orbit.tle"),
    ({"environment": {"sun": False}}, "environment.eclipse"),                              # an eclipse without a Sun
    ({"environment": {"sun": False, "eclipse": False, "solar_pressure": {}}}, "environment.solar_pressure"),
    ({"environment": {"magnetorquers": {}}}, "environment.magnetorquers"),                  # no field to push on
    ({"environment": {"magnetic_field": {}, "magnetorquers": {}}}, "environment.magnetorquers"),  # no momentum to unload
    ({"environment": {"gravity_gradient": True}, "orbit": None}, "environment"),           # no orbit
    ({"environment": {"update_period_s": 0.25}}, "environment.update_period_s"),          # not a whole tick count
    ({"pipeline": {"sensor": {"type": "ideal_attitude"}, "estimator": {"type": "attitude"},
                   "law": {"type": "pointing", "target": "nadir"}}, "orbit": None}, "pipeline.law.target"),
    ({"model": {"system": "planar"}}, "orbit"),                                             # not free-flying
])
def test_a_scenario_that_cannot_fly_is_refused_naming_the_field(blocks, field, tmp_path, capfd):
    path = tmp_path / "fit.yaml"
    path.write_text(yaml.safe_dump(_with(**blocks)))
    assert main(["check", str(path)]) == 2
    out, err = capfd.readouterr()
    assert len(err.strip().splitlines()) == 1 and err.startswith(f"error: {field}: "), err


def test_a_scenario_that_can_fly_passes_the_check(tmp_path, capfd):
    path = tmp_path / "fly.yaml"
    path.write_text(yaml.safe_dump(_with(environment={"drag": {}, "solar_pressure": {},
                                                      "magnetic_field": {}, "magnetorquers": {"desaturation": False}})))
    assert main(["check", str(path)]) == 0



ISS_TLE = ["1 25544U 98067A   24001.50000000  .00016717  00000-0  10270-3 0  9005",
           "2 25544  51.6416 247.4627 0006703 130.5360 325.0288 15.49815350432220"]
# B* = 9.9999 earth radii^-1: SGP4 gives up between 600 s and 3600 s after the epoch (measured)
DECAYING_TLE = [ISS_TLE[0].replace("10270-3", "99999+1"), ISS_TLE[1]]


@pytest.mark.parametrize(("orbit", "duration_s", "field", "reason"), [
    ({"tle": ISS_TLE, "epoch_utc": "2060-01-01T00:00:00"}, 10, "orbit.epoch_utc",
     "SGP4 cannot propagate the TLE to t = 0 s (mean eccentricity is outside the range 0.0 to 1.0)"),
    ({"tle": DECAYING_TLE}, 7200, "orbit.tle", "SGP4 cannot propagate the TLE to t = 7210 s"),
    ({"tle": [ISS_TLE[0].replace("98067A", "98067\u00c5"), ISS_TLE[1]]}, 10, "orbit.tle[0]", "not ASCII"),
])
def test_a_tle_sgp4_cannot_fly_over_the_run_is_refused_at_load(orbit, duration_s, field, reason, tmp_path, capfd):
    path = tmp_path / "tle.yaml"
    path.write_text(yaml.safe_dump(_with(orbit=orbit, sim={"duration_s": duration_s, "dt_s": 0.1}),
                                   allow_unicode=True))
    assert main(["check", str(path)]) == 2
    err = capfd.readouterr().err
    assert len(err.strip().splitlines()) == 1 and err.startswith(f"error: {field}: ") and reason in err, err


def test_set_with_no_value_removes_a_key_so_a_tles_own_epoch_stands(tmp_path):
    from testbed.scenario.loading import load_scenario

    path = tmp_path / "tle.yaml"
    path.write_text(yaml.safe_dump(_with(orbit={"tle": ISS_TLE, "epoch_utc": "2024-06-01T00:00:00"})))
    orbit = load_scenario(str(path), ["orbit.epoch_utc="]).orbit
    assert orbit.epoch().utc == (orbit.satrec.jdsatepoch, orbit.satrec.jdsatepochF)  # 2024 day 1.5
    assert sum(orbit.epoch().utc) == 2460311.0
    assert load_scenario(str(path), ["orbit.no_such_key="]).orbit.epoch_utc == "2024-06-01T00:00:00"
