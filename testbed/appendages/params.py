"""The `model.appendages:` block: solar-array wings of hinged panels and fuel-slosh models.

Every vector is in bus axes, every position from the bus origin. A wing is a chain of panels on
parallel hinge lines: the first hinge sits on the bus at `hinge_position_m`, each further hinge at
the outboard edge of the panel before it, `length_m` along `span_axis`. A slosh model is one of
the literature's equivalent mechanical models of a propellant mode (docs/theory/flexible.md):
a spring-mass (a mass on slide joints with springs) or a spherical pendulum (a mass on a rod
with two hinges at its pivot).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from testbed.errors import InputError
from testbed.math.validation import check_principal_inertia, check_unit_vector
from testbed.scenario.schema import join, param

MAX_POSITION_M = 1e3  # a hinge or a tank this far from the bus origin is off any spacecraft
MAX_PANELS, MAX_WINGS, MAX_SLOSH = 8, 8, 8
# two axes typed by hand (four figures) are normal when |a . b| is below this
NORMAL_TOLERANCE = 1e-3


HOST_SYSTEMS: set[str] = set()  # the systems whose `model:` block has an `appendages` field


def hosts_appendages(system: str) -> None:
    """Declare that system `system`'s params have the `appendages: AppendagesParams | None` field."""
    HOST_SYSTEMS.add(system)


def carries_appendages(system: str) -> bool:
    return system in HOST_SYSTEMS


def has_appendages(scenario) -> bool:
    """Whether `scenario`'s spacecraft has panels or slosh masses: springs store energy, so its
    kinetic energy alone is no conserved quantity."""
    return carries_appendages(scenario.system) and scenario.model.appendages is not None


def orthonormal(first, second, path: str, second_name: str) -> tuple[np.ndarray, np.ndarray]:
    """The unit `first` and the unit `second` made exactly normal to it (Gram-Schmidt), after
    checking they are normal to within NORMAL_TOLERANCE; `path` names `second` in the error."""
    a, b = np.asarray(first, float), np.asarray(second, float)
    if abs(a @ b) > NORMAL_TOLERANCE:
        raise InputError(join(path, second_name), f"must be normal to the other axis, got a dot product {a @ b:.4g}")
    b = b - (a @ b) * a
    return a, b / np.linalg.norm(b)


@dataclass(kw_only=True)
class PanelParams:
    """One rigid panel of a wing, hinged at its inboard edge to the bus or to the panel before it."""

    mass_kg: float = param(gt=0, doc="the panel's mass")
    length_m: float = param(gt=0, le=MAX_POSITION_M, doc="hinge to outboard edge, along the span (the next panel's hinge)")
    width_m: float = param(1.0, gt=0, le=MAX_POSITION_M, doc="along the hinge axis (drawn; sets the default inertia)")
    thickness_m: float = param(0.03, gt=0, le=MAX_POSITION_M, doc="drawn; sets the default inertia")
    com_offset_m: float | None = param(None, ge=0, le=MAX_POSITION_M, doc="hinge line to CoM along the span; None: length_m / 2")
    inertia_kg_m2: list[float] | None = param(None, length=3, doc=(
        "principal moments about the CoM along (span, hinge, normal); None: a uniform box of the panel's size"))
    stiffness_nm_rad: float = param(gt=0, doc="torsional spring of the hinge (MuJoCo joint stiffness)")
    damping_nms_rad: float = param(0.0, ge=0, doc="torsional damper of the hinge (MuJoCo joint damping)")
    range_deg: list[float] | None = param(None, length=2, ge=-180, le=180, doc="hinge stops [low, high]; None: free")
    initial_angle_deg: float = param(0.0, ge=-180, le=180, doc="hinge deflection at the start (free decay)")

    def offset(self) -> float:
        """The CoM's distance from the hinge line along the span [m]."""
        return self.length_m / 2.0 if self.com_offset_m is None else self.com_offset_m

    def inertia(self) -> np.ndarray:
        """Principal moments about the CoM along (span, hinge, normal) [kg m^2]: the given ones, or
        a uniform box's m (b^2 + t^2, a^2 + t^2, a^2 + b^2) / 12 (a = length, b = width, t =
        thickness; a plate of no thickness would sit on the triangle inequality's edge, which
        MuJoCo's compiler refuses at round-off)."""
        if self.inertia_kg_m2 is not None:
            return np.asarray(self.inertia_kg_m2, float)
        a, b, t = self.length_m, self.width_m, self.thickness_m
        return self.mass_kg * np.array([b * b + t * t, a * a + t * t, a * a + b * b]) / 12.0

    def hinge_inertia(self) -> float:
        """J = I_hinge + m d^2: the panel's inertia about its own hinge line [kg m^2]."""
        return float(self.inertia()[1] + self.mass_kg * self.offset() ** 2)

    def validate(self, path: str) -> None:
        if self.inertia_kg_m2 is not None:
            check_principal_inertia(self.inertia_kg_m2, join(path, "inertia_kg_m2"))
        if self.range_deg is not None:
            low, high = self.range_deg
            if not low < 0.0 < high:
                raise InputError(join(path, "range_deg"), f"needs low < 0 < high (the rest angle 0 inside), got {self.range_deg}")
            if not low <= self.initial_angle_deg <= high:
                raise InputError(join(path, "initial_angle_deg"), f"{self.initial_angle_deg:g} deg lies outside range_deg {self.range_deg}")


@dataclass(kw_only=True)
class WingParams:
    """A solar-array wing: a chain of 1 ... MAX_PANELS panels on parallel hinge lines."""

    hinge_position_m: list[float] = param(length=3, ge=-MAX_POSITION_M, le=MAX_POSITION_M,
                                          doc="the root hinge's point on the bus")
    hinge_axis: list[float] = param(length=3, doc="unit hinge axis, shared by every panel of the wing")
    span_axis: list[float] = param(length=3, doc="unit direction the wing extends in at rest, normal to hinge_axis")
    panels: list[PanelParams] = param(doc="root first")

    def validate(self, path: str) -> None:
        self.hinge_axis = check_unit_vector(self.hinge_axis, join(path, "hinge_axis")).tolist()
        span = check_unit_vector(self.span_axis, join(path, "span_axis"))
        self.span_axis = orthonormal(self.hinge_axis, span, path, "span_axis")[1].tolist()
        if not 1 <= len(self.panels) <= MAX_PANELS:
            raise InputError(join(path, "panels"), f"needs 1 to {MAX_PANELS} panels, got {len(self.panels)}")

    def frame(self) -> np.ndarray:
        """Rotation bus <- wing: columns (span, hinge, span x hinge), each panel's body axes."""
        span, hinge = np.asarray(self.span_axis, float), np.asarray(self.hinge_axis, float)
        return np.column_stack([span, hinge, np.cross(span, hinge)])


@dataclass(kw_only=True)
class SloshParams:
    """One propellant slosh mode as an equivalent mechanical model (docs/theory/flexible.md)."""

    model: Literal["spring_mass", "pendulum"] = param(doc="spring_mass: slide joints with springs; pendulum: a mass on a rod")
    mass_kg: float = param(gt=0, doc="the slosh mass (the mode's share of the propellant)")
    position_m: list[float] = param(length=3, ge=-MAX_POSITION_M, le=MAX_POSITION_M, doc=(
        "spring_mass: the mass's rest point; pendulum: the pivot"))
    # spring_mass
    frequency_hz: float | None = param(None, gt=0, doc="spring_mass: sqrt(k/m) / 2 pi, the clamped frequency")
    damping_ratio: float = param(0.0, ge=0, lt=1, doc="spring_mass: c / (2 sqrt(k m)) on each slide")
    slide_axes: list[list[float]] = param([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], doc=(
        "spring_mass: 1 to 3 mutually normal unit axes the mass slides along"))
    initial_offsets_m: list[float] | None = param(None, ge=-MAX_POSITION_M, le=MAX_POSITION_M, doc=(
        "spring_mass: displacement along each slide axis at the start"))
    # pendulum
    length_m: float | None = param(None, gt=0, le=MAX_POSITION_M, doc="pendulum: pivot to mass")
    rod_axis: list[float] = param([0.0, 0.0, -1.0], length=3, doc="pendulum: unit direction pivot -> mass at rest")
    damping_nms_rad: float = param(0.0, ge=0, doc="pendulum: damper at each of the two pivot hinges")
    initial_angles_deg: list[float] = param([0.0, 0.0], length=2, ge=-90, le=90, doc=(
        "pendulum: the rod's angles about its two hinge axes at the start"))

    def validate(self, path: str) -> None:
        defaults = SloshParams(model=self.model, mass_kg=self.mass_kg, position_m=self.position_m)
        other = {"spring_mass": ("damping_nms_rad", "rod_axis", "initial_angles_deg"),
                 "pendulum": ("damping_ratio", "slide_axes", "initial_offsets_m")}[self.model]
        for name in other:  # a field of the other model, given: a mistake, not to be ignored
            if getattr(self, name) != getattr(defaults, name):
                raise InputError(join(path, name), f"is not a field of a {self.model} slosh model")
        if self.model == "spring_mass":
            if self.frequency_hz is None:
                raise InputError(join(path, "frequency_hz"), "a spring_mass slosh model needs its frequency")
            if self.length_m is not None:
                raise InputError(join(path, "length_m"), "is for a pendulum; a spring_mass takes frequency_hz")
            if not 1 <= len(self.slide_axes) <= 3:
                raise InputError(join(path, "slide_axes"), f"needs 1 to 3 axes, got {len(self.slide_axes)}")
            axes = [check_unit_vector(a, join(path, f"slide_axes[{i}]")) for i, a in enumerate(self.slide_axes)]
            for i in range(1, len(axes)):
                for j in range(i):
                    axes[i] = orthonormal(axes[j], axes[i], path, f"slide_axes[{i}]")[1]
            self.slide_axes = [a.tolist() for a in axes]
            if self.initial_offsets_m is not None and len(self.initial_offsets_m) != len(axes):
                raise InputError(join(path, "initial_offsets_m"),
                                 f"gives {len(self.initial_offsets_m)} offsets for {len(axes)} slide axes")
        else:
            if self.length_m is None:
                raise InputError(join(path, "length_m"), "a pendulum slosh model needs its length")
            if self.frequency_hz is not None:
                raise InputError(join(path, "frequency_hz"), "is for a spring_mass; a pendulum takes length_m")
            self.rod_axis = check_unit_vector(self.rod_axis, join(path, "rod_axis")).tolist()

    def stiffness(self) -> float:
        """spring_mass: k = m (2 pi f)^2 [N/m]."""
        return self.mass_kg * (2.0 * np.pi * self.frequency_hz) ** 2

    def slide_damping(self) -> float:
        """spring_mass: c = 2 zeta sqrt(k m) [N s/m]."""
        return 2.0 * self.damping_ratio * np.sqrt(self.stiffness() * self.mass_kg)

    def offsets(self) -> list[float]:
        return self.initial_offsets_m if self.initial_offsets_m is not None else [0.0] * len(self.slide_axes)

    def hinge_axes(self) -> tuple[np.ndarray, np.ndarray]:
        """pendulum: two unit axes normal to the rod and to each other (bus axes): the rod's two
        swing directions."""
        rod = np.asarray(self.rod_axis, float)
        helper = np.eye(3)[int(np.argmin(np.abs(rod)))]
        first = np.cross(rod, helper)
        first /= np.linalg.norm(first)
        return first, np.cross(rod, first)


@dataclass(kw_only=True)
class AppendagesParams:
    """What hangs on the bus besides the actuators: wings of hinged panels and slosh masses."""

    wings: list[WingParams] = param([], doc="solar-array wings, each a chain of hinged panels")
    slosh: list[SloshParams] = param([], doc="propellant slosh modes, each a spring-mass or a pendulum")

    def validate(self, path: str) -> None:
        if len(self.wings) > MAX_WINGS:
            raise InputError(join(path, "wings"), f"at most {MAX_WINGS} wings, got {len(self.wings)}")
        if len(self.slosh) > MAX_SLOSH:
            raise InputError(join(path, "slosh"), f"at most {MAX_SLOSH} slosh models, got {len(self.slosh)}")
        if not self.wings and not self.slosh:
            raise InputError(path, "lists no wings and no slosh: leave the block out for a rigid bus")
