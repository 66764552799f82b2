"""The trace of a run in orbit: the orbit view's Earth, path and bus (testbed/recording/orbit_drawing.py)."""

from __future__ import annotations

import numpy as np
from rerun.chunk import RrdReader

import testbed


def test_a_run_in_orbit_draws_the_earth_the_path_and_the_bus_on_it(tmp_path):
    """The orbit view: the Earth, one path strip per chunk joined end to end through the
    recorded positions (in Mm), the bus placed at each sample's position."""
    path = tmp_path / "orbit.rrd"
    result = testbed.run("orbit_libration", out=path, overrides=["sim.duration_s=2000"])
    entities = {str(c.entity_path) for c in RrdReader(str(path)).stream()}
    assert {"/orbit_space/earth", "/orbit_space/bus"} <= entities
    strips = []
    for chunk in RrdReader(str(path)).stream():
        if str(chunk.entity_path).startswith("/orbit_space/path/"):
            batch = chunk.to_record_batch()
            strips.append((int(str(chunk.entity_path).rsplit("/", 1)[1]),
                           np.array(batch.column("LineStrips3D:strips").to_pylist()[0][0])))
    points = np.concatenate([s for _, s in sorted(strips, key=lambda p: p[0])])
    _, positions = result.trace["truth/orbit_position"]
    unique = points[np.r_[True, np.any(np.diff(points, axis=0) != 0, axis=1)]]
    np.testing.assert_allclose(unique, positions / 1e6, rtol=1e-6)


def test_the_recorded_orbit_is_the_state_at_each_sample_on_a_clock_that_drifts():
    """MuJoCo's clock is a sum of 0.1 s steps: at 2310 s it reads 1e-9 s short, and an update
    due then used to wait one control tick and read the grid a whole update late from there (the
    recorded state and every torque). The recorded orbit over 2600 s matches the orbit's own
    state at each sample time to the interpolation's 1e-3 m (it was 7.6 km off, 1 s late)."""
    from testbed.orbit.config import OrbitParams
    from testbed.scenario.schema import load

    orbit = {"altitude_km": 450, "inclination_deg": 70, "raan_deg": 200, "j2": True}
    data = {"name": "clock", "model": {"system": "satellite", "inertia_kg_m2": [10, 12, 8], "mass_kg": 20},
            "orbit": orbit, "initial": {"quat": [1, 0, 0, 0]},
            "sim": {"duration_s": 2600, "dt_s": 0.1, "control_period_s": 0.1, "trace_period_s": 10},
            "environment": {"update_period_s": 1, "gravity_gradient": False, "sun": False, "eclipse": False}}
    result = testbed.run(data)
    assert result.status == "ok", result.error
    t, positions = result.trace["truth/orbit_position"]
    propagator = load(OrbitParams, orbit, "orbit").propagator()
    expected = np.array([propagator.state(time)[0] for time in t])
    assert t[-1] == 2600.0
    assert np.max(np.linalg.norm(positions - expected, axis=1)) < 1e-3
