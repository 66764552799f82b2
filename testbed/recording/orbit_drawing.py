"""Drawing a run in orbit into its trace: the Earth, the orbit's path and the bus on it, in
ECI with lengths in thousands of km (Mm), under the entity `orbit_space` (its own 3D view)."""

from __future__ import annotations

import numpy as np
from testbed.recording.rerun_sdk import rr

ORBIT_SPACE = "orbit_space"
ORBIT_SIGNAL = "truth/orbit_position"
EARTH_RADIUS_MM = 6.378137
BUS_DRAWN_HALF_SIZE_MM = 0.25  # the bus drawn far larger than it is, to be seen against the Earth


def write_orbit_static(rec) -> None:
    """The Earth (a wireframe sphere) and the drawn bus's box and axes."""
    rec.log(f"{ORBIT_SPACE}/earth", rr.Ellipsoids3D(half_sizes=[[EARTH_RADIUS_MM] * 3], colors=[[70, 120, 200, 120]],
                                                    fill_mode="majorwireframe"), static=True)
    half = BUS_DRAWN_HALF_SIZE_MM
    rec.log(f"{ORBIT_SPACE}/bus", rr.Boxes3D(half_sizes=[[half] * 3], colors=[[230, 230, 240]]), static=True)
    rec.log(f"{ORBIT_SPACE}/bus/axes", rr.Arrows3D(vectors=np.eye(3) * 3 * half,
                                                   colors=[[220, 60, 60], [60, 200, 60], [60, 60, 220]]), static=True)


def write_orbit(rec, chunk, times, strip: int, last_point) -> tuple[int, np.ndarray | None]:
    """The bus's position and attitude at a chunk's samples, and the chunk's stretch of the path
    (one line strip per chunk, joined to the last point of the one before); returns the next
    strip number and the last point."""
    positions = chunk.signals[ORBIT_SIGNAL] / 1e6
    keep = np.all(np.isfinite(positions), axis=1)
    if not keep.any():
        return strip, last_point
    columns = {"translation": positions}
    if "truth/quat" in chunk.signals:
        columns["quaternion"] = chunk.signals["truth/quat"][:, [1, 2, 3, 0]]  # Rerun: xyzw
    rec.send_columns(f"{ORBIT_SPACE}/bus", indexes=[times], columns=rr.Transform3D.columns(**columns))
    points = positions[keep] if last_point is None else np.vstack([last_point, positions[keep]])
    rec.log(f"{ORBIT_SPACE}/path/{strip}", rr.LineStrips3D([points], colors=[[250, 200, 40]]), static=True)
    return strip + 1, points[-1]
