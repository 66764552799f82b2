"""Sun and Earth exclusion of a star tracker: blinded when a bright body lies within a cone
about the boresight. The directions come from the orbit geometry (a plant that gives
`sun_direction_body()` / `earth_direction_body()`, unit vectors in body axes); until a system
gives them, asking for an exclusion angle is refused before the run."""

from __future__ import annotations

import numpy as np

# what a plant must give, per exclusion field of StarTrackerParams
DIRECTIONS = {"sun_exclusion_deg": "sun_direction_body", "earth_exclusion_deg": "earth_direction_body"}


def blinded(boresight: np.ndarray, direction: np.ndarray, half_angle_rad: float) -> bool:
    """True when unit `direction` lies within `half_angle_rad` of unit `boresight` (both body axes)."""
    return float(np.dot(boresight, direction)) > np.cos(half_angle_rad)
