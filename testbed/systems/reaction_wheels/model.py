"""The reaction-wheel spacecraft (models/reaction_wheels.xml): its parameters and `build`.

`ReactionWheelsParams` is the scenario's `model:` block; `build` writes the bus's mass, full
inertia tensor (MjSpec `fullinertia`) and CoM and adds one body, hinge and torque motor per wheel.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import mujoco
import numpy as np

from testbed.appendages.build import add_appendages
from testbed.appendages.params import AppendagesParams, hosts_appendages
from testbed.errors import InputError
from testbed.math.validation import MASS_RANGE_KG, check_in_range, check_inertia_tensor, check_unit_vector
from testbed.scenario.schema import join, param
from testbed.scenario.shipped_files import compile_model, load_spec
from testbed.systems.free_bus import BUS_BODY, MAX_COM_M, full_inertia, set_bus_inertia_tensor
from testbed.systems.reaction_wheels.wheel_array import (
    ISOTROPIC_SKEW_DEG, MAX_WHEELS, WheelArray, nasa_standard_axes, pyramid_axes, three_orthogonal_axes)

RPM = 2.0 * np.pi / 60.0  # rad/s per rpm
FRICTION_SOLVER_TOLERANCE = 1e-15
WHEEL_RADIUS_M, WHEEL_HALF_WIDTH_M = 0.15, 0.03  # what the 3D view draws (the inertias are given)
PRESETS = {"three_orthogonal": lambda p: three_orthogonal_axes(), "pyramid": lambda p: pyramid_axes(p.skew_deg),
           "nasa_standard": lambda p: nasa_standard_axes()}


@dataclass(kw_only=True)
class WheelParams:
    """One wheel's properties: every wheel of a preset array, a custom wheel's defaults."""

    spin_inertia_kg_m2: float = param(0.02, gt=0, doc="Js: inertia about the spin axis")
    transverse_inertia_kg_m2: float = param(0.012, gt=0, doc="Jt: inertia about an axis across the spin axis, at the wheel's CoM")
    mass_kg: float = param(4.0, gt=0)
    max_torque_nm: float = param(0.2, gt=0, doc="motor torque limit")
    max_speed_rpm: float = param(6000.0, gt=0, le=1e5, doc="speed limit relative to the bus (momentum saturation)")
    viscous_friction_nms_rad: float = param(0.0, ge=0, doc="bearing viscous friction (MuJoCo joint damping)")
    coulomb_friction_nm: float = param(0.0, ge=0, doc="bearing Coulomb friction (MuJoCo joint frictionloss)")


@dataclass(kw_only=True)
class CustomWheel:
    """One wheel of a custom array (`array: custom`); a property left out is `model.wheel`'s."""

    axis: list[float] = param(length=3, doc="unit spin axis, bus axes")
    position_m: list[float] | None = param(None, length=3, doc="wheel centre in bus axes (default mount_radius_m along the axis)")
    spin_inertia_kg_m2: float | None = param(None, gt=0)
    transverse_inertia_kg_m2: float | None = param(None, gt=0)
    mass_kg: float | None = param(None, gt=0)
    max_torque_nm: float | None = param(None, gt=0)
    max_speed_rpm: float | None = param(None, gt=0, le=1e5)
    viscous_friction_nms_rad: float | None = param(None, ge=0)
    coulomb_friction_nm: float | None = param(None, ge=0)

    def validate(self, path: str) -> None:
        self.axis = list(check_unit_vector(self.axis, join(path, "axis")))

    def resolved(self, defaults: WheelParams) -> WheelParams:
        """This wheel's properties, each field it leaves out taken from `defaults`."""
        given = {name: getattr(self, name) for name in defaults.__dataclass_fields__ if getattr(self, name) is not None}
        return WheelParams(**(vars(defaults) | given))



@dataclass(kw_only=True)
class WheelsParams:
    """An array of 1 to 8 reaction wheels on a bus: the `model:` block of reaction_wheels, and
    the `model.wheels:` block of a CMG cluster with wheels (a hybrid bus)."""

    array: Literal["three_orthogonal", "pyramid", "nasa_standard", "custom"] = "pyramid"
    skew_deg: float = param(ISOTROPIC_SKEW_DEG, gt=0, lt=90, doc="pyramid: each spin axis's angle from the bus z axis")
    mount_radius_m: float = param(0.3, ge=0, le=100, doc="a preset wheel's centre lies this far along its spin axis")
    wheel: WheelParams = field(default_factory=WheelParams)
    wheels: list[CustomWheel] = param([], doc="array custom: the wheels, [{axis, ...any field of model.wheel}]")
    wheel_speeds_rpm: list[float] | None = param(None, doc="initial speeds relative to the bus, one per wheel (default 0)")

    def validate(self, path: str) -> None:
        if self.array == "custom":
            if not 1 <= len(self.wheels) <= MAX_WHEELS:
                raise InputError(join(path, "wheels"), f"array custom needs 1 to {MAX_WHEELS} wheels, got {len(self.wheels)}")
        elif self.wheels:
            raise InputError(join(path, "wheels"), f"lists wheels for the preset array {self.array}: "
                                                   "set array: custom to give your own")
        for i, unit in enumerate(self.units()):
            wheel_path = join(path, f"wheels[{i}]" if self.array == "custom" else "wheel")
            if unit.spin_inertia_kg_m2 > 2.0 * unit.transverse_inertia_kg_m2 * (1 + 1e-12):
                raise InputError(join(wheel_path, "spin_inertia_kg_m2"), "an axisymmetric wheel needs Js <= 2 Jt, got "
                                 f"{unit.spin_inertia_kg_m2:g} > 2 x {unit.transverse_inertia_kg_m2:g}")
        count = len(self.axes())
        if self.wheel_speeds_rpm is not None:
            speeds_path = join(path, "wheel_speeds_rpm")
            if len(self.wheel_speeds_rpm) != count:
                raise InputError(speeds_path, f"gives {len(self.wheel_speeds_rpm)} speeds; the array has {count} wheels")
            for i, (speed, unit) in enumerate(zip(self.wheel_speeds_rpm, self.units())):
                if abs(speed) > unit.max_speed_rpm:
                    raise InputError(f"{speeds_path}[{i}]", f"{speed:g} rpm is beyond the wheel's "
                                                            f"max_speed_rpm {unit.max_speed_rpm:g}")

    def axes(self) -> np.ndarray:
        """The unit spin axes, (n, 3), bus axes."""
        if self.array == "custom":
            return np.array([w.axis for w in self.wheels], dtype=float)
        return PRESETS[self.array](self)

    def units(self) -> list[WheelParams]:
        """Each wheel's properties."""
        if self.array == "custom":
            return [w.resolved(self.wheel) for w in self.wheels]
        return [self.wheel] * len(self.axes())

    def positions(self) -> np.ndarray:
        """Each wheel's centre [m], bus axes, (n, 3)."""
        axes = self.axes()
        given = [w.position_m for w in self.wheels] if self.array == "custom" else [None] * len(axes)
        return np.array([self.mount_radius_m * a if p is None else p for a, p in zip(axes, given)], dtype=float)

    def initial_speeds(self) -> np.ndarray:
        """Initial wheel speeds relative to the bus [rad/s]."""
        speeds = self.wheel_speeds_rpm if self.wheel_speeds_rpm is not None else [0.0] * len(self.axes())
        return np.asarray(speeds, dtype=float) * RPM

    def wheel_array(self) -> WheelArray:
        units = self.units()
        return WheelArray(axes=self.axes(),
                          spin_inertia=np.array([u.spin_inertia_kg_m2 for u in units]),
                          torque_max=np.array([u.max_torque_nm for u in units]),
                          speed_max=np.array([u.max_speed_rpm for u in units]) * RPM,
                          viscous=np.array([u.viscous_friction_nms_rad for u in units]),
                          coulomb=np.array([u.coulomb_friction_nm for u in units]))


@dataclass(kw_only=True)
class ReactionWheelsParams(WheelsParams):
    """A rigid bus with a full inertia tensor carrying 1 to 8 reaction wheels (docs/theory/reaction-wheels.md)."""

    system: str = "reaction_wheels"
    inertia_tensor_kg_m2: list[list[float]] = param([[350.0, 0.0, 0.0], [0.0, 420.0, 0.0], [0.0, 0.0, 300.0]],
                                                    length=3, doc="the bus's inertia tensor about its CoM, bus axes, "
                                                    "products of inertia off the diagonal (I_xy = -sum m x y)")
    mass_kg: float = param(500.0, gt=0, doc="the bus alone (the wheels add theirs)")
    appendages: AppendagesParams | None = param(None, doc="solar-array wings and slosh masses on the bus (absent: a rigid bus)")
    com_m: list[float] = param([0.0, 0.0, 0.0], length=3, ge=-MAX_COM_M, le=MAX_COM_M,
                               doc="the bus's CoM from the bus origin (where the wheels are placed), bus axes")

    def validate(self, path: str) -> None:
        check_inertia_tensor(self.inertia_tensor_kg_m2, join(path, "inertia_tensor_kg_m2"))
        check_in_range(join(path, "mass_kg"), self.mass_kg, MASS_RANGE_KG, "kg")
        super().validate(path)


hosts_appendages("reaction_wheels")  # its `appendages` field


def wheel_tensor(axis, spin: float, transverse: float) -> np.ndarray:
    """An axisymmetric wheel's inertia tensor in bus axes: Jt 1 + (Js - Jt) a a^T [kg m^2]."""
    a = np.asarray(axis, dtype=float)
    return transverse * np.eye(3) + (spin - transverse) * np.outer(a, a)


def wheel_names(count: int) -> list[str]:
    return [f"wheel{i + 1}" for i in range(count)]


def motor_names(count: int) -> list[str]:
    return [f"wheel_motor{i + 1}" for i in range(count)]


def build(params: ReactionWheelsParams, dt: float, integrator: str) -> mujoco.MjModel:
    """Compile models/reaction_wheels.xml with the bus's mass, inertia tensor and CoM, the wheels
    (`add_wheels`) and any appendages after them (testbed.appendages.build), all through MjSpec."""
    spec = load_spec("reaction_wheels.xml", dt, integrator)
    tensor = check_inertia_tensor(params.inertia_tensor_kg_m2, "model.inertia_tensor_kg_m2")
    set_bus_inertia_tensor(spec, tensor, params.mass_kg, params.com_m)
    bus = spec.body(BUS_BODY)
    add_wheels(spec, bus, params)
    if params.appendages is not None:
        add_appendages(spec, bus, params.appendages)
    return compile_model(spec)


def add_wheels(spec: mujoco.MjSpec, bus, params: WheelsParams) -> None:
    """Add to `bus` (an MjSpec body) one body, hinge (bearing friction: damping and frictionloss)
    and torque motor (ctrlrange the torque limit) per wheel of `params`, after everything the
    spec already holds: the wheels' joints and motors come last in the compiled model."""
    axes, units, positions = params.axes(), params.units(), params.positions()
    if any(unit.coulomb_friction_nm for unit in units):
        # Coulomb friction is a frictionloss constraint: at MuJoCo's default tolerance (1e-8) the Newton
        # solver accepts its warm start without an iteration, and the friction's reaction on the bus is
        # off by ~0.5 %: the total momentum of a tumbling bus drifted 1e-5 N m s a second. At 1e-15 it
        # iterates once and the drift is round-off (tests/test_reaction_wheels.py).
        spec.option.tolerance = FRICTION_SOLVER_TOLERANCE
    for name, motor, axis, unit, position in zip(wheel_names(len(axes)), motor_names(len(axes)), axes, units, positions):
        wheel = bus.add_body(name=name, pos=position)
        wheel.mass = unit.mass_kg
        wheel.fullinertia = full_inertia(wheel_tensor(axis, unit.spin_inertia_kg_m2, unit.transverse_inertia_kg_m2))
        wheel.ipos = [0.0, 0.0, 0.0]  # the CoM on the hinge axis at the body origin (MjSpec leaves it unset)
        wheel.explicitinertial = True
        wheel.add_joint(name=name, type=mujoco.mjtJoint.mjJNT_HINGE, axis=axis,
                        damping=unit.viscous_friction_nms_rad, frictionloss=unit.coulomb_friction_nm)
        wheel.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[WHEEL_RADIUS_M, 0, 0],
                       fromto=np.concatenate([-WHEEL_HALF_WIDTH_M * axis, WHEEL_HALF_WIDTH_M * axis]),
                       contype=0, conaffinity=0, mass=0, rgba=[0.9, 0.5, 0.1, 1])
        spec.add_actuator(name=motor, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT,
                          gear=[1, 0, 0, 0, 0, 0], ctrllimited=True,
                          ctrlrange=[-unit.max_torque_nm, unit.max_torque_nm])
