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
                                                      "magnetic_field": {}, "magnetorquers": {}})))
    assert main(["check", str(path)]) == 0

