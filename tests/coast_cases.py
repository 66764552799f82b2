"""What the coast tests of buses with wheels share: the initial state they start from and the
largest drift of the total angular momentum over a coast."""

from __future__ import annotations

import numpy as np


class Initial:
    """The scenario's initial state as a plant's `initialise` reads it: body rate [rad/s], attitude (w, x, y, z)."""

    def __init__(self, omega=(0.0, 0.0, 0.0), quat=(1.0, 0.0, 0.0, 0.0)):
        self.omega, self.quat = np.asarray(omega, float), np.asarray(quat, float)


def coast_drift(plant, chunks: int, steps: int) -> float:
    """max over `chunks` samples, `steps` physics steps apart, of |L(t) - L(0)| [N m s], the total
    angular momentum about the CoM in world axes, with no command applied."""
    start = plant.angular_momentum_world()
    drift = 0.0
    for _ in range(chunks):
        plant.step(steps)
        drift = max(drift, float(np.linalg.norm(plant.angular_momentum_world() - start)))
    return drift
