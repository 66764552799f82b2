"""Star tracker: the bus attitude with noise across and about the boresight, late, with dropouts.

The tracker frame has its z axis on the boresight b and its x axis along the part of `x_axis`
normal to b (both body axes). A sample taken at t reports the attitude of t - L (latency L):

    q̃ = q(t - L) ∘ exp(δθ / 2),   δθ = C [σ_c n_1, σ_c n_2, σ_a n_3]ᵀ   (body axes, n ~ N(0, I))

with C the tracker-to-body matrix, σ_c the noise across and σ_a about the boresight: the
measurement covariance in body axes is R = C diag(σ_c², σ_c², σ_a²) Cᵀ (the small-rotation
error model of Markley & Crassidis, "Fundamentals of Spacecraft Attitude Determination and
Control", 2014, ch. 6, the MEKF's attitude measurement). During an outage window the tracker reports no
sample (`valid` 0, the last sample held).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from testbed.errors import InputError
from testbed.math.quaternion import quat_from_rotation_vector, quat_mul
from testbed.scenario.schema import join, param
from testbed.stages.white_noise import WhiteNoise

ARCSEC = np.pi / (180.0 * 3600.0)
# A tracker's 1 sigma: from far below any tracker's to half a turn; the filter squares and inverts
# it, which under- or overflows far outside (1e-300 arcsec squared is below the smallest double).
NOISE_RANGE_ARCSEC = (1e-6, 648000.0)


@dataclass(kw_only=True)
class StarTrackerParams:
    boresight: list[float] = param([0.0, 0.0, 1.0], length=3, doc="boresight direction, body axes (any length > 0)")
    x_axis: list[float] = param([1.0, 0.0, 0.0], length=3, doc="tracker x axis: its part normal to the boresight")
    cross_boresight_noise_arcsec: float = param(ge=NOISE_RANGE_ARCSEC[0], le=NOISE_RANGE_ARCSEC[1],
                                                doc="1 sigma about each axis across the boresight")
    about_boresight_noise_arcsec: float = param(ge=NOISE_RANGE_ARCSEC[0], le=NOISE_RANGE_ARCSEC[1],
                                                doc="1 sigma about the boresight (roll)")
    sample_period_s: float | None = param(None, gt=0, doc="update period (default: the sensor period)")
    latency_s: float = param(0.0, ge=0, doc="age of the attitude a sample reports")
    outages_s: list[list[float]] = param([], doc="dropout windows [start, end) in s: no sample inside")
    sun_exclusion_deg: float | None = param(None, gt=0, lt=180, doc="no sample while the Sun is within this "
                                            "angle of the boresight (needs an orbit)")
    earth_exclusion_deg: float | None = param(None, gt=0, lt=180, doc="no sample while the Earth's limb is "
                                              "within this angle of the boresight (needs an orbit)")
    moon_exclusion_deg: float | None = param(None, gt=0, lt=180, doc="no sample while the Moon's centre is "
                                             "within this angle of the boresight (needs an orbit)")
    seed: int = param(0, ge=0, doc="noise seed: the same seed gives the same samples bit for bit")

    def validate(self, path: str) -> None:
        b = np.asarray(self.boresight, float)
        if not np.linalg.norm(b) > 1e-9:
            raise InputError(join(path, "boresight"), f"must have a length > 0, got {self.boresight}")
        x = np.asarray(self.x_axis, float)
        if np.linalg.norm(np.cross(b / np.linalg.norm(b), x)) < 1e-6:
            raise InputError(join(path, "x_axis"), "must not be parallel to the boresight (or zero)")
        for i, window in enumerate(self.outages_s):
            if len(window) != 2 or not window[0] < window[1]:
                raise InputError(join(path, f"outages_s[{i}]"), f"must be [start, end] with start < end, got {window}")


def tracker_frame(params: StarTrackerParams) -> np.ndarray:
    """C: the tracker's x, y, z (boresight) axes as the columns, in body axes."""
    z = np.asarray(params.boresight, float)
    z = z / np.linalg.norm(z)
    x = np.asarray(params.x_axis, float)
    x = x - (x @ z) * z
    x = x / np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def measurement_covariance(params: StarTrackerParams) -> np.ndarray:
    """R = C diag(σ_c², σ_c², σ_a²) Cᵀ [rad², body axes] (module doc)."""
    frame = tracker_frame(params)
    sigma = np.array([params.cross_boresight_noise_arcsec] * 2 + [params.about_boresight_noise_arcsec]) * ARCSEC
    return frame @ np.diag(sigma**2) @ frame.T


def tracked_attitude(quat, frame, sigma, draw) -> np.ndarray:
    """q̃ = q ∘ exp(δθ / 2), δθ = C (σ ∘ draw) (module doc), on (..., 4) rows of trackers (frame
    (..., 3, 3), sigma (..., 3)) for standard normal draws (..., 3)."""
    return quat_mul(quat, quat_from_rotation_vector(np.matvec(frame, sigma * draw)))


class StarTracker:
    """The tracker of the module doc, called every `every` sensor periods; `delay` periods late."""

    def __init__(self, params: StarTrackerParams, delay: int):
        self.frame = tracker_frame(params)
        self.sigma = np.array([params.cross_boresight_noise_arcsec] * 2 + [params.about_boresight_noise_arcsec]) * ARCSEC
        self.outages = [tuple(window) for window in params.outages_s]
        self.images = deque(maxlen=delay + 1)  # the true attitudes of the last delay + 1 periods
        self.noise = WhiteNoise(params.seed)

    def seen(self, quat) -> None:
        """Keep the true attitude of this sensor period (for the latency)."""
        self.images.append(np.array(quat, float))

    def available(self, t: float) -> bool:
        return not any(start <= t < end for start, end in self.outages)

    def sample(self) -> np.ndarray:
        """The attitude `delay` periods ago (the first one before that) with the noise of the module doc."""
        return tracked_attitude(self.images[0], self.frame, self.sigma, self.noise.add(0.0, 1.0, 3))
