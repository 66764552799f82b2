"""The star tracker's Sun and Earth exclusion against the geometry worked here by hand: the
Sun's direction from SOFA's Earth ephemeris, the Earth's disc of angular radius asin(R/r)
about nadir, and in a run the instant the limb enters the cone (testbed/sensors/exclusion.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

import testbed
from testbed.orbit.config import OrbitParams
from testbed.scenario.schema import load
from testbed.scenario.shipped_files import SCENARIO_DIR
from testbed.sensors.exclusion import EARTH, SUN, Exclusion

MU, RE = 3.986004418e14, 6378137.0


def test_the_sun_blinds_a_tracker_pointed_within_its_angle_of_it():
    """Boresight body z; the attitude turns z onto the Sun's direction (from erfa.epv00 here,
    less the orbit position), then 29.9 and 30.1 deg off it: blinded, blinded, clear at 30 deg."""
    import erfa

    orbit = load(OrbitParams, {"altitude_km": 700, "inclination_deg": 98, "epoch_utc": "2027-02-03T04:05:06"}, "orbit")
    exclusion = Exclusion([0.0, 0.0, 1.0], 30.0, None, orbit, 1.0, 100.0)
    epoch = orbit.epoch()
    r, _ = orbit.propagator().state(50.0)
    sun = -np.asarray(erfa.epv00(*epoch.tt(50.0))[0]["p"], float) * 1.495978707e11 - r
    s = sun / np.linalg.norm(sun)
    side = np.cross(s, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    for off_deg, expected in ((0.0, SUN), (29.9, SUN), (30.1, 0)):
        boresight = math.cos(math.radians(off_deg)) * s + math.sin(math.radians(off_deg)) * side
        axis = np.cross([0.0, 0.0, 1.0], boresight)   # the rotation taking body z to the boresight
        angle = math.atan2(np.linalg.norm(axis), boresight[2])
        axis /= np.linalg.norm(axis)
        quat = np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * axis])
        assert exclusion.cause(50.0, quat) == expected, off_deg


@pytest.mark.slow
def test_the_earths_limb_blinds_the_tracker_when_it_enters_the_cone():
    """A bus at rest in ECI, boresight +x, on an equatorial circular orbit at 500 km: the angle
    from the boresight to nadir is pi - u(t), u the argument of latitude, so the limb (angular
    radius asin(R/a)) enters the 25 deg cone when u = pi - asin(R/a) - 25 deg. Started so that
    this falls at 200 s, the trace shows `tracker_excluded` 2 (the Earth) and no tracker sample
    from the first 0.1 s sample at or after that instant, clear before it."""
    a = RE + 500e3
    n = math.sqrt(MU / a**3)
    limb = math.asin(RE / a)
    start_deg = math.degrees(math.pi - limb - math.radians(25.0) - n * 200.0)
    data = yaml.safe_load((SCENARIO_DIR / "attitude_outage_mekf.yaml").read_text())
    data["sim"]["duration_s"] = 260
    data["orbit"] = {"altitude_km": 500, "inclination_deg": 0, "true_anomaly_deg": start_deg, "j2": False}
    tracker = data["pipeline"]["sensor"]["star_tracker"]
    tracker.update(boresight=[1, 0, 0], x_axis=[0, 1, 0], earth_exclusion_deg=25, outages_s=[])
    result = testbed.run(data)
    assert result.status == "ok", result.error
    t, excluded = result.trace["sensor/tracker_excluded"]
    _, available = result.trace["sensor/tracker_available"]
    first = t[np.argmax(excluded[:, 0] > 0)]
    assert 200.0 - 1e-6 <= first <= 200.1 + 1e-6
    assert np.all(excluded[t < 199.99, 0] == 0) and np.all(excluded[t > 200.2, 0] == EARTH)
    assert np.all(available[t > 200.2, 0] == 0) and np.all(available[t < 199.99, 0] == 1)
