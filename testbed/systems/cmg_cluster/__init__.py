"""Satellite with a cluster of 3 ... 8 single-gimbal CMGs of any geometry (models/cmg_cluster.xml).

- arrays.py   the `array:` block: presets (pyramid, box, roof, three_orthogonal, rhombus) and custom units
- model.py    `CmgClusterParams` (the `model:` block, with the bus's full inertia tensor) and `build`
- envelope_command.py  `testbed envelope` for a scenario or an array: the envelope's extents
- hybrid_plant.py      with `model.wheels`: the hybrid bus, CMGs and reaction wheels (HybridPlant)
- hybrid_allocator.py  the allocator `hybrid_split`: the law's torque split between wheels and CMGs

The plant, the servos, the faults, the reduced model and the cluster geometry are the CMG
machinery of testbed/systems/cmg_rhombus, which reads every unit from the compiled model.
"""

from testbed.appendages.build import initial_positions
from testbed.systems.cmg_cluster import envelope_command, hybrid_allocator  # noqa: F401  (register)
from testbed.systems.cmg_cluster.hybrid_plant import HybridPlant
from testbed.systems.cmg_cluster.model import CmgClusterParams, build
from testbed.systems.cmg_rhombus import MAX_DT_OVER_ROTOR_TAU, CmgPlant
from testbed.systems.cmg_rhombus.faults import check_fault_times
from testbed.systems.registry import system


@system("cmg_cluster", CmgClusterParams)
def make_plant(params: CmgClusterParams, sim) -> CmgPlant:
    check_fault_times(params.faults, sim.end_time_s - sim.control_period_s,  # the last tick
                      sim.dt_s / MAX_DT_OVER_ROTOR_TAU, sim.dt_s)
    plant = CmgPlant if params.wheels is None else HybridPlant
    start = [] if params.appendages is None else initial_positions(params.appendages)
    return plant(build(params, sim.dt_s, sim.integrator), params, sim.control_period_s, start)


__all__ = ["CmgClusterParams", "build", "make_plant"]
