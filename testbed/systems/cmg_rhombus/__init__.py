"""Satellite with four single-gimbal CMGs in the rhombus layout of SEEDS §004 (models/cmg_rhombus.xml).

- model.py   `CmgRhombusParams` (the `model:` block) and `build` through MjSpec

Everything else, the plant, its servos, faults, imbalance, the reduced model, the envelope, the
steering allocators of the system and its metrics, is the CMG machinery of any array, which
testbed/systems/cmg_cluster owns; the rhombus is one of its arrays (`rhombus_axes`).
"""

from testbed.systems.cmg_cluster.faults import check_fault_times
from testbed.systems.cmg_cluster.plant import CmgPlant
from testbed.systems.cmg_cluster.units import MAX_DT_OVER_ROTOR_TAU
from testbed.systems.cmg_rhombus.model import CmgRhombusParams, build
from testbed.systems.registry import system


@system("cmg_rhombus", CmgRhombusParams)
def make_plant(params: CmgRhombusParams, sim) -> CmgPlant:
    check_fault_times(params.faults, sim.end_time_s - sim.control_period_s,  # the last tick
                      sim.dt_s / MAX_DT_OVER_ROTOR_TAU, sim.dt_s)
    return CmgPlant(build(params, sim.dt_s, sim.integrator), params, sim.control_period_s)


__all__ = ["CmgRhombusParams", "build", "make_plant"]
