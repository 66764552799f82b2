"""The wheel array as the controllers know it: spin axes, spin inertias and limits (SI units).

A wheel's axial momentum relative to the bus is h_i = Js_i Omega_i (Omega_i its speed relative to
the bus); the array's is H = A h with A = [a_1 ... a_n] (3 x n), the spin axes as columns
(docs/theory/reaction-wheels.md, "The model").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MAX_WHEELS = 8
ISOTROPIC_SKEW_DEG = float(np.degrees(np.arccos(1.0 / np.sqrt(3.0))))  # equal capacity along x, y and z


def three_orthogonal_axes() -> np.ndarray:
    """Spin axes along the bus x, y and z axes, (3, 3)."""
    return np.eye(3)


def pyramid_axes(skew_deg: float) -> np.ndarray:
    """Four spin axes at `skew_deg` [deg] from the bus z axis, at azimuths 0, 90, 180, 270 deg, (4, 3):
    a_i = (sin b cos phi_i, sin b sin phi_i, cos b). At b = arccos(1/sqrt 3) = 54.74 deg the array's
    capacity is the same along x, y and z (sum_i (a_i . e)^2 = 4/3 for each axis e)."""
    skew = np.radians(skew_deg)
    azimuth = np.radians([0.0, 90.0, 180.0, 270.0])
    return np.column_stack([np.sin(skew) * np.cos(azimuth), np.sin(skew) * np.sin(azimuth),
                            np.full(4, np.cos(skew))])


def nasa_standard_axes() -> np.ndarray:
    """Three orthogonal wheels plus a fourth, skewed along (1, 1, 1)/sqrt 3, (4, 3)."""
    return np.vstack([np.eye(3), np.ones(3) / np.sqrt(3.0)])


@dataclass(frozen=True)
class WheelArray:
    """What an allocator may know of the array (the plant's `description()`), every array (n,)
    but `axes` (n, 3): unit spin axes in bus axes; `spin_inertia` Js [kg m^2]; `torque_max` the
    motor's torque limit [N m]; `speed_max` the speed limit relative to the bus [rad/s];
    `viscous` [N m s/rad] and `coulomb` [N m] the bearing friction, -viscous Omega - coulomb sign(Omega)
    on the wheel."""

    axes: np.ndarray
    spin_inertia: np.ndarray
    torque_max: np.ndarray
    speed_max: np.ndarray
    viscous: np.ndarray
    coulomb: np.ndarray

    @property
    def count(self) -> int:
        return len(self.axes)

    @property
    def distribution(self) -> np.ndarray:
        """A = [a_1 ... a_n] (3, n): the body vector A u of per-wheel axial quantities u."""
        return self.axes.T

    @property
    def momentum_max(self) -> np.ndarray:
        """Each wheel's momentum at its speed limit, Js Omega_max [N m s]."""
        return self.spin_inertia * self.speed_max

    def wheel_momentum(self, rates) -> np.ndarray:
        """h_i = Js_i Omega_i [N m s] of wheel speeds `rates` [rad/s] relative to the bus, (..., n)."""
        return self.spin_inertia * np.asarray(rates, dtype=float)

    def momentum(self, rates) -> np.ndarray:
        """H = A h [N m s, bus axes] of wheel speeds `rates` (..., n) [rad/s]: shape (..., 3)."""
        return self.wheel_momentum(rates) @ self.axes

    def friction(self, rates) -> np.ndarray:
        """The bearing friction torque each wheel's motor must overcome at `rates` [rad/s]: viscous
        Omega + coulomb sign(Omega) [N m] (the torque on the wheel is its negative)."""
        rates = np.asarray(rates, dtype=float)
        return self.viscous * rates + self.coulomb * np.sign(rates)
