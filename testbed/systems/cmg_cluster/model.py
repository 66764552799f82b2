"""The CMG cluster spacecraft (models/cmg_cluster.xml): its parameters and `build`.

`CmgClusterParams` is the scenario's `model:` block: the bus (principal moments and products of
inertia), the `array:` (arrays.py), every unit field the rhombus has (CmgUnitsParams) and,
for a hybrid bus, the reaction wheels' `wheels:` block (the reaction_wheels system's).
`build` adds the array's units to the bus through MjSpec, laid out and named as in
models/cmg_rhombus.xml, and applies every field with the rhombus's own `compile_units`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np

from testbed.appendages.build import add_appendages, initial_positions
from testbed.appendages.params import AppendagesParams, hosts_appendages
from testbed.errors import InputError
from testbed.math.validation import check_principal_inertia
from testbed.scenario.schema import join, param
from testbed.scenario.shipped_files import compile_model, load_spec
from testbed.systems.cmg_cluster.arrays import ArrayLayout, ArrayParams, UnitParams, layout
from testbed.systems.cmg_rhombus.cluster import unit_names
from testbed.systems.cmg_rhombus.model import (INITIAL_KEY, CmgUnitsParams, UnitBuild, compile_units,
                                              unit_actuator_names)
from testbed.systems.free_bus import BUS_BODY, set_bus_inertia_tensor
from testbed.systems.reaction_wheels.model import WheelsParams, add_wheels

ROTOR_QUAT = [0.70710678, -0.70710678, 0.0, 0.0]  # rotor local z = gimbal local y (the spin axis e_i)


@dataclass(kw_only=True)
class CmgClusterParams(CmgUnitsParams):
    """The bus plus a cluster of 3 ... 8 single-gimbal CMGs of any geometry (arrays.py).

    inertia_kg_m2: the bus's moments of inertia (Ixx, Iyy, Izz) about its CoM, bus axes;
        products_of_inertia_kg_m2: (Ixy, Ixz, Iyz), the tensor's off-diagonal entries (its
        eigenvalues must be positive and obey the triangle inequality).
    gimbal_angles_deg: the initial angles, one per unit; None: the array's own (arrays.py).
    rotor_static_imbalance_kg_m, rotor_dynamic_imbalance_kg_m2: one per unit; [] (the default):
        every rotor balanced.
    wheels: reaction wheels on the same bus, the reaction_wheels system's array block
        (testbed.systems.reaction_wheels.model.WheelsParams); None: none.
    appendages: hinged panels and slosh masses (testbed.appendages); None: a rigid bus.
    The other fields are CmgRhombusParams's, for every unit.
    """

    system: str = "cmg_cluster"
    array: ArrayParams = field(default_factory=ArrayParams)  # a preset with its parameters, or custom units
    inertia_kg_m2: list[float] = param([800.0, 1000.0, 1200.0], length=3, doc="moments of inertia of the bus")
    products_of_inertia_kg_m2: list[float] = param([0.0, 0.0, 0.0], length=3, doc="Ixy, Ixz, Iyz of the bus")
    gimbal_angles_deg: list[float] | None = param(None, doc="initial gimbal angles; None: the array's")
    rotor_static_imbalance_kg_m: list[float] = param([], ge=0, doc="Us of each rotor (simple jitter)")
    rotor_dynamic_imbalance_kg_m2: list[float] = param([], ge=0, doc="Ud of each rotor (simple jitter)")
    wheels: WheelsParams | None = param(None, doc="reaction wheels on the same bus (a hybrid bus; absent: none)")
    appendages: AppendagesParams | None = param(None, doc="solar-array wings and slosh masses on the bus (absent: a rigid bus)")

    def units(self) -> ArrayLayout:
        """The array's units (arrays.layout)."""
        return layout(self.array)

    def unit_count(self) -> int:
        return self.units().count

    def inertia_tensor(self) -> np.ndarray:
        """The bus inertia tensor [kg m^2], (3, 3)."""
        (ixx, iyy, izz), (ixy, ixz, iyz) = self.inertia_kg_m2, self.products_of_inertia_kg_m2
        return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])

    def validate(self, path: str) -> None:
        tensor_field = "products_of_inertia_kg_m2" if any(self.products_of_inertia_kg_m2) else "inertia_kg_m2"
        check_principal_inertia(np.linalg.eigvalsh(self.inertia_tensor()).tolist(), join(path, tensor_field))
        count = self.unit_count()
        for name in ("gimbal_angles_deg", "rotor_static_imbalance_kg_m", "rotor_dynamic_imbalance_kg_m2"):
            values = getattr(self, name)
            given = values is not None and (name == "gimbal_angles_deg" or values)  # []: balanced rotors
            if given and len(values) != count:
                raise InputError(join(path, name), f"gives {len(values)} values; the array has {count} units")
        for name in ("rotor_static_imbalance_kg_m", "rotor_dynamic_imbalance_kg_m2"):
            if not getattr(self, name):  # none given: every rotor balanced
                setattr(self, name, [0.0] * count)
        super().validate(path)


hosts_appendages("cmg_cluster")  # its `appendages` field


def build(params: CmgClusterParams, dt: float, integrator: str = "RK4") -> mujoco.MjModel:
    """Compile models/cmg_cluster.xml with the array's units added and every field of `params`
    applied through MjSpec; with `params.wheels`, the reaction_wheels builder's wheels added to
    the same bus after the units (`add_wheels`), their initial speeds in the keyframe; with
    `params.appendages`, the panels and slosh masses after those (testbed.appendages.build), at
    rest in the keyframe (the plant deflects them: Plant.place_appendages)."""
    spec = load_spec("cmg_cluster.xml", dt, integrator)
    set_bus_inertia_tensor(spec, params.inertia_tensor(), params.mass_kg)
    units = params.units()
    add_units(spec, units.count)
    angles = units.gimbal_angles_deg if params.gimbal_angles_deg is None else params.gimbal_angles_deg
    model = compile_units(spec, params, dt, [unit_build(params, position, frame, own) for position, frame, own
                                             in zip(units.positions, units.frames(), units.own)], angles)
    if params.wheels is None and params.appendages is None:
        return model
    # the units are placed and sized in the spec now: the wheels' and appendages' joints (and the
    # wheels' motors) come after theirs, so the keyframe grows at its end
    key = spec.key(INITIAL_KEY)
    if params.wheels is not None:
        add_wheels(spec, spec.body(BUS_BODY), params.wheels)
        count = len(params.wheels.axes())
        key.qpos = list(key.qpos) + [0.0] * count
        key.qvel = list(key.qvel) + params.wheels.initial_speeds().tolist()
        key.ctrl = list(key.ctrl) + [0.0] * count
    if params.appendages is not None:
        add_appendages(spec, spec.body(BUS_BODY), params.appendages)
        count = len(initial_positions(params.appendages))
        key.qpos = list(key.qpos) + [0.0] * count
        key.qvel = list(key.qvel) + [0.0] * count
    return compile_model(spec)


def unit_build(params: CmgClusterParams, position, frame, own: UnitParams | None) -> UnitBuild:
    """One unit at `position` [m] with gimbal frame `frame`: its own rotor momentum, masses and
    gimbal inertia where `own` gives them, the model's otherwise."""
    def chosen(name: str, common):
        value = None if own is None else getattr(own, name)
        return common if value is None else value
    return UnitBuild(position, frame, chosen("rotor_momentum_nms", params.rotor_momentum_nms),
                     chosen("rotor_mass_kg", params.rotor_mass_kg), chosen("gimbal_mass_kg", params.gimbal_mass_kg),
                     chosen("gimbal_inertia_kg_m2", params.gimbal_inertia_kg_m2))


def add_units(spec, count: int) -> None:
    """Add `count` gimbal bodies to the bus, each with its hinge, visual frame and rotor, then
    their actuators in models/cmg_rhombus.xml's order (all gimbal-rate servos, all gimbal motors,
    all rotor-speed loops) and the keyframe; compile_units places and sizes them."""
    bus = spec.body(BUS_BODY)
    gimbal_class, rotor_class = spec.find_default("gimbal"), spec.find_default("rotor")
    visual_class = spec.find_default("gimbal_frame_visual")
    gimbals, rotors = unit_names(count)
    for gimbal_name, rotor_name in zip(gimbals, rotors):
        gimbal = bus.add_body(name=gimbal_name, explicitinertial=True)
        gimbal.add_joint(gimbal_class, name=gimbal_name)
        gimbal.add_geom(visual_class)
        rotor = gimbal.add_body(name=rotor_name, quat=ROTOR_QUAT, explicitinertial=True)
        rotor.add_joint(rotor_class, name=rotor_name)
        rotor.add_geom(rotor_class)
    servos, speed_loops, motors = unit_actuator_names(count)
    joint = mujoco.mjtTrn.mjTRN_JOINT
    for name, gimbal_name in zip(servos, gimbals):
        servo = spec.add_actuator(name=name, target=gimbal_name, trntype=joint)
        servo.set_to_intvelocity(kp=1.0, kv=0.0)  # the gains are compile_units's
        servo.actrange = [-1e6, 1e6]
    for name, gimbal_name in zip(motors, gimbals):
        spec.add_actuator(name=name, target=gimbal_name, trntype=joint).set_to_motor()
    for name, rotor_name in zip(speed_loops, rotors):
        spec.add_actuator(name=name, target=rotor_name, trntype=joint).set_to_velocity(kv=1.0)
    spec.add_key(name=INITIAL_KEY)
