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
