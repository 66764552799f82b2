"""Physical systems by name (`model: {system: NAME, ...}`): params schema + plant factory.

Each system is one MJCF file in models/ and one module in testbed/domains/ that knows its
joints by name; this module holds the scenario-facing parameters (units in the key names)
and connects them to the domain's build function.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from testbed import schema
from testbed import gyrostat_pair_plant, variable_gyrostat_plant
from testbed.domains import cmg_rhombus, gyrostat, planar, satellite
from testbed.errors import InputError
from testbed.physical_checks import check_principal_inertia
from testbed.schema import join, param


@dataclass(kw_only=True)
class SatelliteParams:
    """A rigid bus driven by ideal body torques."""

    system: str = "satellite"
    inertia_kg_m2: list[float] = param([800.0, 1000.0, 1200.0], length=3, doc="principal inertia, body axes")
    mass_kg: float = param(1000.0, gt=0)

    def validate(self, path: str) -> None:
        check_principal_inertia(self.inertia_kg_m2, join(path, "inertia_kg_m2"))


@dataclass(kw_only=True)
class CmgRhombusParams(SatelliteParams):
    """The bus plus four single-gimbal CMGs in the rhombus layout (SEEDS §004)."""

    system: str = "cmg_rhombus"
    alpha_deg: float = param(float(np.degrees(np.arctan(np.sqrt(2.0)))), gt=0, lt=90)
    rotor_momentum_nms: float = param(50.0, gt=0, doc="h of each rotor at nominal speed")
    rotor_speed_rpm: float = param(6000.0, gt=0)
    rotor_transverse_ratio: float = param(0.6, ge=0.5, doc="Jt / Js of the rotor")
    rotor_mass_kg: float = param(10.0, gt=0)
    gimbal_mass_kg: float = param(5.0, gt=0)
    gimbal_inertia_kg_m2: list[float] = param([0.03, 0.02, 0.02], length=3, gt=0)
    cmg_distance_m: float = param(0.5, gt=0)
    servo_natural_frequency_rad_s: float = param(316.0, gt=0)
    servo_damping_ratio: float = param(1.0, gt=0)
    rotor_speed_time_constant_s: float = param(0.02, gt=0)
    gimbal_angles_deg: list[float] = param([45.0, -45.0, -45.0, 45.0], length=4)


def _satellite_plant(p: SatelliteParams, sim):
    from testbed.plant import Plant

    model = satellite.build(satellite.SatelliteParams(
        bus_inertia=tuple(p.inertia_kg_m2), bus_mass=p.mass_kg, timestep=sim.dt_s, integrator=sim.integrator))
    return Plant(satellite.Satellite(model))


def _cmg_plant(p: CmgRhombusParams, sim):
    from testbed.cmg_plant import CmgPlant

    params = cmg_rhombus.CmgRhombusParams(
        bus_inertia=tuple(p.inertia_kg_m2), bus_mass=p.mass_kg, timestep=sim.dt_s, integrator=sim.integrator,
        alpha=float(np.radians(p.alpha_deg)), rotor_momentum=p.rotor_momentum_nms,
        rotor_speed_rpm=p.rotor_speed_rpm, rotor_transverse_ratio=p.rotor_transverse_ratio,
        rotor_mass=p.rotor_mass_kg, gimbal_inertia=tuple(p.gimbal_inertia_kg_m2), gimbal_mass=p.gimbal_mass_kg,
        cmg_distance=p.cmg_distance_m, servo_natural_frequency=p.servo_natural_frequency_rad_s,
        servo_damping_ratio=p.servo_damping_ratio, rotor_speed_time_constant=p.rotor_speed_time_constant_s,
        beta0=tuple(np.radians(p.gimbal_angles_deg)))
    try:
        model = cmg_rhombus.build(params)
    except InputError as exc:  # the domain names its own parameter; name the scenario's key
        raise InputError(f"model.{_CMG_KEYS.get(exc.field, exc.field)}", exc.reason) from None
    return CmgPlant(model)


def _planar_plant(p, sim):
    from testbed.planar_plant import PlanarPlant

    return PlanarPlant(p, sim)


# Domain parameter name -> scenario key, for errors the domain raises while building.
_CMG_KEYS = {"servo_natural_frequency": "servo_natural_frequency_rad_s",
             "rotor_speed_time_constant": "rotor_speed_time_constant_s", "timestep": "sim.dt_s"}


@dataclass(frozen=True)
class System:
    params: type
    make_plant: Callable      # (params, sim: SimConfig) -> Plant
    free_flying: bool = True  # a free body with conserved total momentum when unactuated


SYSTEMS: dict[str, System] = {
    "satellite": System(SatelliteParams, _satellite_plant),
    "cmg_rhombus": System(CmgRhombusParams, _cmg_plant),
    "gyrostat": System(
        gyrostat.GyrostatParams,
        lambda p, sim: gyrostat.GyrostatPlant(gyrostat.build(p, sim.dt_s, sim.integrator), p)),
    # hinge-mounted planar rig (Avdeev & Kaptsova 2016): no free body, no momentum metrics
    "planar": System(planar.PlanarParams, _planar_plant, free_flying=False),
    # SEEDS 002 (variable structure, program motion) and 003 (leader/follower pair)
    "gyrostat_variable": System(variable_gyrostat_plant.VariableGyrostatScenarioParams,
                                variable_gyrostat_plant.make_plant),
    "gyrostat_pair": System(gyrostat_pair_plant.GyrostatPairScenarioParams, gyrostat_pair_plant.make_plant),
}


def load_params(config: dict, path: str):
    config = dict(config)
    name = config.get("system")
    if name not in SYSTEMS:
        raise InputError(f"{path}.system", f"unknown system {name!r} (one of {', '.join(sorted(SYSTEMS))})")
    return name, schema.load(SYSTEMS[name].params, config, path)


def make_plant(scenario):
    return SYSTEMS[scenario.system].make_plant(scenario.model, scenario.sim)


def is_free_flying(scenario) -> bool:
    return SYSTEMS[scenario.system].free_flying
