"""White measurement noise for sensor stages: one seeded generator per stage, so the same seed
gives the same samples bit for bit, and a noise-free channel draws nothing."""

from __future__ import annotations

import numpy as np


class WhiteNoise:
    def __init__(self, seed: int):
        self.seed = seed  # kept so that a campaign can read back the seed a stage got
        self.rng = np.random.default_rng(seed)

    def add(self, value, sigma: float, size=None):
        """value + sigma N(0, 1) (`size` independent draws), or `value` itself when sigma is 0."""
        return value + sigma * self.rng.standard_normal(size) if sigma else value
