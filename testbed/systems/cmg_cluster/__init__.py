"""Satellite with a cluster of 3 ... 8 single-gimbal CMGs of any geometry (models/cmg_cluster.xml),
and the CMG machinery every single-gimbal system runs on (the seed's rhombus, testbed/systems/cmg_rhombus, too).

- arrays.py   the `array:` block: presets (pyramid, box, roof, three_orthogonal, rhombus) and custom units
- model.py    `CmgClusterParams` (the `model:` block, with the bus's full inertia tensor) and `build`
- units.py    the units' common fields (`CmgUnitsParams`) and `compile_units`, which places and sizes them
- cluster.py  the cluster geometry H(beta), dH/dbeta read from the compiled model
- plant.py    joints and servos by name; the plant the runner steps
- plants_group.py     many worlds' plants in a batch on (N, ...) arrays: the servos' tick vectorised
- gimbal_servo.py     the gimbal-rate servos (intvelocity, feedforward) and where the momentum drift comes from
- servo_tracking.py   the servo's miss of its held command, beyond the jumps (jump_refinement.py) it was handed
- reduced_model.py    the reduced (gyrostat) model, reference `reduced_cmg`
- momentum_envelope.py the envelope and singular surfaces
- momentum_gauge.py   what momentum the cluster can hold and what torque it can give (its convex hull)
- rotor_imbalance.py  rotor static and dynamic imbalance as their force and torque on the bus
- faults.py           timed unit faults (`model.faults`) injected into the plant
- vscmg_allocator.py  the allocator `vscmg`: variable-speed rotors, Schaub-Junkins weighted steering
- stages.py           the open-loop allocator `gimbal_rate_profile`
- metrics.py          servo tracking of the held gimbal-rate command
- envelope_command.py  `testbed envelope` for a scenario or an array: the envelope's extents
- hybrid_plant.py      with `model.wheels`: the hybrid bus, CMGs and reaction wheels (HybridPlant)
- hybrid_allocator.py  the allocator `hybrid_split`: the law's torque split between wheels and CMGs
"""

from testbed.appendages.build import initial_positions
from testbed.systems.cmg_cluster import (envelope_command, hybrid_allocator, metrics, reduced_model,  # noqa: F401
                                         stages, vscmg_allocator)  # (register)
from testbed.systems.cmg_cluster.faults import check_fault_times
from testbed.systems.cmg_cluster.hybrid_plant import HybridPlant
from testbed.systems.cmg_cluster.model import CmgClusterParams, build
from testbed.systems.cmg_cluster.plant import CmgPlant
from testbed.systems.cmg_cluster.units import MAX_DT_OVER_ROTOR_TAU
from testbed.systems.registry import system


@system("cmg_cluster", CmgClusterParams)
def make_plant(params: CmgClusterParams, sim) -> CmgPlant:
    check_fault_times(params.faults, sim.end_time_s - sim.control_period_s,  # the last tick
                      sim.dt_s / MAX_DT_OVER_ROTOR_TAU, sim.dt_s)
    plant = CmgPlant if params.wheels is None else HybridPlant
    start = [] if params.appendages is None else initial_positions(params.appendages)
    return plant(build(params, sim.dt_s, sim.integrator), params, sim.control_period_s, start)


__all__ = ["CmgClusterParams", "build", "make_plant"]
