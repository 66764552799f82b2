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
    exclusion = Exclusion([0.0, 0.0, 1.0], 30.0, None, None, orbit, 1.0, 100.0)
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


AU = 1.495978707e11


def _moon_from_meeus(lam_deg, beta_deg, tt):
    """Unit GCRS direction of a Moon at ecliptic longitude and latitude of date (Meeus's tables)."""
    import erfa

    lam, beta = math.radians(lam_deg), math.radians(beta_deg)
    ecliptic = np.array([math.cos(beta) * math.cos(lam), math.cos(beta) * math.sin(lam), math.sin(beta)])
    return erfa.ecm06(*tt).T @ ecliptic   # ecm06: GCRS to the ecliptic of date (IAU 2006)


def test_the_moon_is_where_meeus_worked_example_puts_it():
    """Meeus, *Astronomical Algorithms* (1998), example 47.a, 1992 April 12 0h TD: geocentric
    longitude 133.162655 deg, latitude -3.229126 deg (mean ecliptic of date), distance 368 409.7
    km. The library (Meeus's theory less the light-time term of the mean longitude, which its
    docs name: +0.000206666 deg on the longitude) meets the printed figures to their last digit
    (5e-7 deg, 0.05 km); the conversion to the ecliptic of date is SOFA's (1e-8 deg)."""
    import erfa

    from testbed.orbit.moon import moon_positions
    from testbed.orbit.time_scales import Epoch

    tt = (2448724.5, 0.0)
    epoch = Epoch(*erfa.taiutc(*erfa.tttai(*tt)))   # run time 0 at that TT (to a microsecond)
    moon = moon_positions(epoch, [0.0])[0]
    assert np.linalg.norm(moon) / 1e3 == pytest.approx(368409.7, abs=0.06)
    light_time_deg = 218.31665436 - 218.3164477   # the two theories' mean longitudes at J2000
    expected = _moon_from_meeus(133.162655 + light_time_deg, -3.229126, tt)
    miss_deg = math.degrees(math.acos(min(1.0, moon @ expected / np.linalg.norm(moon))))
    assert miss_deg < 1e-6
    # and without the light-time term the direction is off by it: the test can tell 0.7"
    plain = _moon_from_meeus(133.162655, -3.229126, tt)
    assert math.degrees(math.acos(moon @ plain / np.linalg.norm(moon))) == pytest.approx(light_time_deg, rel=0.01)


@pytest.mark.slow
def test_the_moon_blinds_the_tracker_exactly_while_its_centre_is_within_the_angle():
    """A bus at rest in ECI on a 600 km, 60 deg Keplerian circle; the boresight is set on the
    Moon as seen from the bus at 100 s (the test's own circle and SOFA's moon98 at the test's
    own TT), and the exclusion angle is 0.05 deg. The parallax (7.6 km/s across 380 000 km) and
    the Moon's motion sweep that direction by ~1e-3 deg/s, so the Moon enters and leaves the cone
    within the run. At every 0.1 s sample `tracker_excluded` is 4 (the Moon) exactly when the
    test's angle is below 0.05 deg, and `truth/moon_direction` (held from each 1 s environment
    update) is the test's direction there: both to 1e-9 rad (the orbit's RK4 and interpolation, < 1 mm, move the direction 3e-12 rad)."""
    import erfa

    from testbed.sensors.exclusion import MOON

    a = RE + 600e3
    n, inclination, raan = math.sqrt(MU / a**3), math.radians(60.0), math.radians(20.0)
    p_axis = np.array([math.cos(raan), math.sin(raan), 0.0])
    q_axis = np.array([-math.sin(raan) * math.cos(inclination), math.cos(raan) * math.cos(inclination),
                       math.sin(inclination)])
    utc = erfa.dtf2d("UTC", 2027, 5, 14, 3, 0, 0.0)
    tai = erfa.utctai(*utc)

    def moon_seen(times):
        times = np.asarray(times, float)
        tt = erfa.taitt(tai[0], tai[1] + times / 86400.0)
        moon = AU * np.asarray(erfa.moon98(*tt)["p"], float).reshape(-1, 3)
        r = a * (np.cos(n * times)[:, None] * p_axis + np.sin(n * times)[:, None] * q_axis)
        towards = moon - r
        return towards / np.linalg.norm(towards, axis=1)[:, None]

    boresight = moon_seen([100.0])[0]
    cone = math.radians(0.05)
    data = yaml.safe_load((SCENARIO_DIR / "attitude_outage_mekf.yaml").read_text())
    data["sim"]["duration_s"] = 200
    data["orbit"] = {"altitude_km": 600, "inclination_deg": 60, "raan_deg": 20, "j2": False,
                     "epoch_utc": "2027-05-14T03:00:00"}
    data["environment"] = {"gravity_gradient": False, "sun": False, "eclipse": False, "moon": True}
    side = np.cross(boresight, [0.0, 0.0, 1.0])
    tracker = data["pipeline"]["sensor"]["star_tracker"]
    tracker.update(boresight=boresight.tolist(), x_axis=side.tolist(), moon_exclusion_deg=0.05, outages_s=[])
    result = testbed.run(data)
    assert result.status == "ok", result.error
    t, excluded = result.trace["sensor/tracker_excluded"]
    _, available = result.trace["sensor/tracker_available"]
    _, quat = result.trace["truth/quat"]
    assert np.max(np.abs(quat - [1.0, 0.0, 0.0, 0.0])) < 1e-12   # at rest: body axes are ECI's
    angle = np.arccos(np.clip(moon_seen(t) @ boresight, -1.0, 1.0))
    decided = np.abs(angle - cone) > 1e-9
    inside = angle < cone
    assert 100 < np.sum(inside) < len(t) - 100   # the Moon enters and leaves the cone in the run
    assert np.array_equal(excluded[decided, 0] == MOON, inside[decided])
    assert np.all(excluded[:, 0] != MOON) or np.array_equal(available[:, 0] == 0, excluded[:, 0] == MOON)
    t_moon, direction = result.trace["truth/moon_direction"]   # held from each 1 s update
    assert np.max(np.linalg.norm(direction - moon_seen(np.floor(t_moon + 1e-9)), axis=1)) < 1e-9
