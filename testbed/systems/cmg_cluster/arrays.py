"""The arrays a CMG cluster can have: the `array:` block, its presets and a user's own units.

Each array is a list of units, each with its gimbal axis g_i, its spin axis at zero gimbal angle
e_i (normal to g_i), its mount position and its rotor momentum, and the gimbal angles it starts
from. The presets (docs/your-spacecraft.md tabulates them):

- `pyramid` (Wie's pyramid, any `count` of 3 ... 8 units): unit i at azimuth phi_i = 2 pi (i-1)/n,
  g_i = (sin b cos phi_i, sin b sin phi_i, cos b) normal to a face tilted by the skew angle b
  (`skew_deg`, 54.74 deg by default), e_i = (-sin phi_i, cos phi_i, 0); for 4 units this is
  H = h (-cb s1 - c2 + cb s3 + c4, c1 - cb s2 - c3 + cb s4, sb (s1 + s2 + s3 + s4)) of Wie's
  singularity analysis of the pyramid. It starts at zero angles (H = 0, full rank).
- `box`: the 4-unit pyramid at b = 90 deg (gimbal axes +-x, +-y), from (45, -45, 45, -45) deg,
  where H = 0 at full rank (at zero angles every torque axis is z).
- `roof`: two pairs of parallel gimbal axes (sin b, 0, cos b) and (-sin b, 0, cos b), b =
  `skew_deg` (45 deg by default), spins at zero angle +y (units 1, 2) and -y (units 3, 4); from
  (45, -45, 45, -45) deg (H = 0, full rank).
- `three_orthogonal`: gimbal axes x, y, z, spins y, z, x at zero angle (no redundancy).
- `rhombus`: the seed's layout (SEEDS §004, alpha `alpha_deg`), as the `cmg_rhombus` system builds it.
- `custom`: `units:` [{gimbal_axis, spin_axis, position_m}], 3 ... 8 of them, each with its own
  rotor_momentum_nms, rotor_mass_kg, gimbal_mass_kg, gimbal_inertia_kg_m2 where it differs from the model's.

Presets mount unit i at `mount_distance_m` from the bus origin, balanced so that the units' CoM
is the origin.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from testbed.errors import InputError
from testbed.math.validation import check_principal_inertia, check_unit_vector
from testbed.scenario.schema import join, param
from testbed.steering.validation import MAX_UNITS, MIN_UNITS  # the clusters a steering law takes

PRESETS = ("pyramid", "box", "roof", "three_orthogonal", "rhombus", "custom")
PYRAMID_SKEW_DEG = float(np.degrees(np.arccos(1.0 / np.sqrt(3.0))))  # 54.7356 deg: Wie's pyramid
ROOF_SKEW_DEG = 45.0
RHOMBUS_ALPHA_DEG = float(np.degrees(np.arctan(np.sqrt(2.0))))  # SEEDS §004
SIGNS = np.array([1.0, 1.0, -1.0, -1.0])  # s_i of SEEDS §004
MAX_MOUNT_M = 1e3  # a unit this far from the bus origin is off any spacecraft
# a spin axis may be this far (|g . e|) from normal to its gimbal axis, as typed by hand (four figures)
NORMAL_TOLERANCE = 1e-3


@dataclass(kw_only=True)
class UnitParams:
    """One CMG of a custom array, bus frame."""

    gimbal_axis: list[float] = param(length=3, doc="unit gimbal axis g_i")
    spin_axis: list[float] = param(length=3, doc="unit spin axis at zero gimbal angle, normal to g_i")
    position_m: list[float] = param([0.0, 0.0, 0.0], length=3, ge=-MAX_MOUNT_M, le=MAX_MOUNT_M,
                                    doc="where the gimbal sits on the bus")
    rotor_momentum_nms: float | None = param(None, gt=0, doc="h_i; None: the model's rotor_momentum_nms")
    rotor_mass_kg: float | None = param(None, gt=0, doc="None: the model's rotor_mass_kg")
    gimbal_mass_kg: float | None = param(None, gt=0, doc="None: the model's gimbal_mass_kg")
    gimbal_inertia_kg_m2: list[float] | None = param(None, length=3, gt=0, doc=(
        "principal inertia of the gimbal frame about (gimbal axis, spin axis, third); None: the model's"))

    def validate(self, path: str) -> None:
        if self.gimbal_inertia_kg_m2 is not None:
            check_principal_inertia(self.gimbal_inertia_kg_m2, join(path, "gimbal_inertia_kg_m2"))


@dataclass(kw_only=True)
class ArrayParams:
    """The array of CMGs: a preset with its parameters, or `custom` units (module doc)."""

    preset: Literal["pyramid", "box", "roof", "three_orthogonal", "rhombus", "custom"] = param("pyramid")
    count: int | None = param(None, ge=MIN_UNITS, le=MAX_UNITS, doc="pyramid: number of units (4 if not given)")
    skew_deg: float | None = param(None, gt=0, le=90, doc="pyramid, roof: gimbal-axis angle from z")
    alpha_deg: float | None = param(None, gt=0, lt=90, doc="rhombus: the seed's angle alpha")
    mount_distance_m: float = param(0.5, ge=0, le=MAX_MOUNT_M, doc="presets: distance of each unit from the bus origin")
    units: list[UnitParams] = param([], doc="custom: the units, 3 ... 8")

    def validate(self, path: str) -> None:
        given = {"count": self.count is not None, "skew_deg": self.skew_deg is not None,
                 "alpha_deg": self.alpha_deg is not None, "units": bool(self.units)}
        allowed = {"pyramid": {"count", "skew_deg"}, "box": set(), "roof": {"skew_deg"},
                   "three_orthogonal": set(), "rhombus": {"alpha_deg"}, "custom": {"units"}}[self.preset]
        for name, present in given.items():
            if present and name not in allowed:
                raise InputError(join(path, name), f"not a parameter of the {self.preset} array")
        if self.preset == "custom" and not MIN_UNITS <= len(self.units) <= MAX_UNITS:
            raise InputError(join(path, "units"), f"a custom array needs {MIN_UNITS} ... {MAX_UNITS} units, "
                             f"got {len(self.units)}")


@dataclass
class ArrayLayout:
    """The units of an array, bus frame: gimbal_axes g_i and spin_axes e_i at zero angle (n, 3)
    unit vectors with g_i . e_i = 0, positions [m] (n, 3), the initial gimbal_angles_deg (n,) and
    what a unit has of its own (`own`: a custom unit's UnitParams, None for a preset's), where it
    differs from the model's common rotor momentum, masses and gimbal inertia."""

    gimbal_axes: np.ndarray
    spin_axes: np.ndarray
    positions: np.ndarray
    gimbal_angles_deg: np.ndarray
    own: list[UnitParams | None]

    @property
    def count(self) -> int:
        return len(self.gimbal_axes)

    def frames(self) -> list[np.ndarray]:
        """Each gimbal frame as a rotation matrix, columns (g_i, e_i, g_i x e_i)."""
        return [np.column_stack([g, e, np.cross(g, e)]) for g, e in zip(self.gimbal_axes, self.spin_axes)]


def layout(array: ArrayParams, path: str = "model.array") -> ArrayLayout:
    """The units of `array` (module doc)."""
    d = array.mount_distance_m
    if array.preset == "custom":
        return _custom(array.units, join(path, "units"))
    if array.preset == "rhombus":
        e, g, _ = rhombus_axes(np.radians(RHOMBUS_ALPHA_DEG if array.alpha_deg is None else array.alpha_deg))
        return _preset(g, e, d * e, [45.0, -45.0, -45.0, 45.0])
    if array.preset == "three_orthogonal":
        g = np.eye(3)
        e = np.roll(np.eye(3), -1, axis=0)  # spins y, z, x
        return _preset(g, e, d * (g - g.mean(axis=0)) / np.linalg.norm(g[0] - g.mean(axis=0)), [0.0] * 3)
    if array.preset == "roof":
        b = np.radians(ROOF_SKEW_DEG if array.skew_deg is None else array.skew_deg)
        a_axis, b_axis = np.array([np.sin(b), 0.0, np.cos(b)]), np.array([-np.sin(b), 0.0, np.cos(b)])
        g = np.array([a_axis, a_axis, b_axis, b_axis])
        y = np.array([0.0, 1.0, 0.0])
        e = np.array([y, y, -y, -y])
        places = np.array([[1.0, 1.0, 0.0], [1.0, -1.0, 0.0], [-1.0, 1.0, 0.0], [-1.0, -1.0, 0.0]]) / np.sqrt(2.0)
        return _preset(g, e, d * places, [45.0, -45.0, 45.0, -45.0])
    count = 4 if array.preset == "box" or array.count is None else array.count
    skew = 90.0 if array.preset == "box" else PYRAMID_SKEW_DEG if array.skew_deg is None else array.skew_deg
    g, e, radial = pyramid_axes(count, np.radians(skew))
    angles = [45.0, -45.0, 45.0, -45.0] if array.preset == "box" else [0.0] * count
    return _preset(g, e, d * radial, angles)


def rhombus_axes(alpha):
    """Unit vectors of SEEDS §004 in the bus frame: e_i (spin at beta = 0), g_i = s_i e_i x z
    (gimbal) and s_i z (where the spin axis turns for beta > 0); each (4, 3).

    CMG i has spin axis cos(b_i) e_i + sin(b_i) s_i z with e1 = (cos a, sin a, 0), e2 = (-cos a, sin a, 0),
    e3 = -e1, e4 = -e2, s = (+1, +1, -1, -1); Rodrigues' formula about g_i gives R(b) e_i = cos b e_i +
    sin b (g_i x e_i), and g_i x e_i = s_i z, so a positive MuJoCo hinge angle b_i about g_i is exactly
    the paper's b_i."""
    c, s = np.cos(alpha), np.sin(alpha)
    e = np.array([[c, s, 0.0], [-c, s, 0.0], [-c, -s, 0.0], [c, -s, 0.0]])
    z = np.array([0.0, 0.0, 1.0])
    g = SIGNS[:, None] * np.cross(e, z)
    return e, g, SIGNS[:, None] * z


def pyramid_axes(count: int, skew: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(g, e, radial) of a pyramid of `count` units at skew angle `skew` [rad] (module doc):
    gimbal axes, spin axes at zero angle and the unit radial directions (cos phi_i, sin phi_i, 0)."""
    phi = 2.0 * np.pi * np.arange(count) / count
    c, s = np.cos(phi), np.sin(phi)
    zero = np.zeros(count)
    g = np.column_stack([np.sin(skew) * c, np.sin(skew) * s, np.full(count, np.cos(skew))])
    return g, np.column_stack([-s, c, zero]), np.column_stack([c, s, zero])


def _preset(g, e, positions, angles) -> ArrayLayout:
    count = len(g)
    return ArrayLayout(np.asarray(g, float), np.asarray(e, float), np.asarray(positions, float),
                       np.asarray(angles, float), [None] * count)


def _custom(units: list[UnitParams], path: str) -> ArrayLayout:
    """A user's units: each axis a unit vector (UNIT_TOLERANCE rule), the spin axis normal to the
    gimbal axis within NORMAL_TOLERANCE and then made exactly normal (Gram-Schmidt)."""
    g, e = [], []
    for i, unit in enumerate(units):
        where = f"{path}[{i}]"
        gimbal = check_unit_vector(unit.gimbal_axis, join(where, "gimbal_axis"))
        spin = check_unit_vector(unit.spin_axis, join(where, "spin_axis"))
        if abs(gimbal @ spin) > NORMAL_TOLERANCE:
            raise InputError(join(where, "spin_axis"), f"must be normal to gimbal_axis: their dot product is "
                             f"{gimbal @ spin:.4g}")
        spin = spin - (gimbal @ spin) * gimbal
        g.append(gimbal)
        e.append(spin / np.linalg.norm(spin))
    if np.linalg.matrix_rank(np.array(g), tol=NORMAL_TOLERANCE) < 2:
        raise InputError(join(path, "gimbal_axis"), "the gimbal axes are all parallel: no gimbal state gives a "
                         "torque along them")
    positions = np.array([unit.position_m for unit in units], dtype=float)
    return ArrayLayout(np.array(g), np.array(e), positions, np.zeros(len(units)), list(units))
