"""The CMG spacecraft of SEEDS §004 (models/cmg_rhombus.xml): its parameters and `build`.

`CmgRhombusParams` is the scenario's `model:` block (units in the key names); `build`
applies every field to the MJCF with MjSpec: the bus mass properties, the rhombus placement
of the four gimbals (angle alpha, testbed.systems.cmg_cluster.arrays.rhombus_axes) and every
unit field through the cluster's `compile_units` (testbed/systems/cmg_cluster/units.py).
"""

from dataclasses import dataclass

import mujoco
import numpy as np

from testbed.math.validation import check_principal_inertia
from testbed.scenario.schema import join, param
from testbed.scenario.shipped_files import load_spec
from testbed.systems.cmg_cluster.arrays import rhombus_axes
from testbed.systems.cmg_cluster.cluster import unit_names
from testbed.systems.cmg_cluster.units import CmgUnitsParams, UnitBuild, compile_units
from testbed.systems.free_bus import set_bus_mass

N_CMG = 4  # units of the seed's rhombus
GIMBALS, ROTORS = unit_names(N_CMG)


@dataclass(kw_only=True)
class CmgRhombusParams(CmgUnitsParams):
    """The bus plus four single-gimbal CMGs in the rhombus layout of the redundant-gyrodyne
    reorientation paper (docs/theory/papers.md).

    inertia_kg_m2: principal inertia of the bus alone about its CoM; the system inertia also
        contains the CMG masses at cmg_distance_m and their own inertias.
    gimbal_angles_deg: initial gimbal angles; the default is the zero-momentum, full-rank set.
    rotor_static_imbalance_kg_m, rotor_dynamic_imbalance_kg_m2: Us and Ud of each rotor, whose
        periodic force and torque on the bus rotor_imbalance.py applies (Basilisk's simple jitter).
    The other fields are CmgUnitsParams's (testbed/systems/cmg_cluster/units.py).
    """

    system: str = "cmg_rhombus"
    inertia_kg_m2: list[float] = param([800.0, 1000.0, 1200.0], length=3, doc="principal inertia of the bus")
    alpha_deg: float = param(float(np.degrees(np.arctan(np.sqrt(2.0)))), gt=0, lt=90)
    cmg_distance_m: float = param(0.5, gt=0)
    gimbal_angles_deg: list[float] = param([45.0, -45.0, -45.0, 45.0], length=4)
    rotor_static_imbalance_kg_m: list[float] = param([0.0] * 4, length=4, ge=0, doc="Us of each rotor (simple jitter)")
    rotor_dynamic_imbalance_kg_m2: list[float] = param([0.0] * 4, length=4, ge=0, doc="Ud of each rotor (simple jitter)")

    def unit_count(self) -> int:
        return N_CMG

    def validate(self, path: str) -> None:
        check_principal_inertia(self.inertia_kg_m2, join(path, "inertia_kg_m2"))
        super().validate(path)


def build(params: CmgRhombusParams, dt: float, integrator: str = "RK4") -> mujoco.MjModel:
    """Compile models/cmg_rhombus.xml with every field of `params` applied through MjSpec."""
    spec = load_spec("cmg_rhombus.xml", dt, integrator)
    set_bus_mass(spec, params.inertia_kg_m2, params.mass_kg)
    e, g, sz = rhombus_axes(np.radians(params.alpha_deg))
    units = [UnitBuild(params.cmg_distance_m * e[i], np.column_stack([g[i], e[i], sz[i]]), params.rotor_momentum_nms,
                       params.rotor_mass_kg, params.gimbal_mass_kg, params.gimbal_inertia_kg_m2) for i in range(N_CMG)]
    return compile_units(spec, params, dt, units, params.gimbal_angles_deg)
