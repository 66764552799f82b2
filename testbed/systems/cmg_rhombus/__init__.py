"""Satellite with four single-gimbal CMGs in the rhombus layout of SEEDS §004 (models/cmg_rhombus.xml).

- model.py            `CmgRhombusParams` (the `model:` block) and `build` through MjSpec
- cluster.py          the cluster geometry H(beta), dH/dbeta read from the compiled model
- plant.py            joints and servos by name; the plant the runner steps
- gimbal_servo.py     the gimbal-rate servos (intvelocity, feedforward) and where the momentum drift comes from
- reduced_model.py    the reduced (gyrostat) model, reference `reduced_cmg`
- momentum_envelope.py the envelope and singular surfaces (`testbed envelope`: testbed/systems/cmg_cluster)
- momentum_gauge.py   what momentum the cluster can hold and what torque it can give (its convex hull)
- rotor_imbalance.py  rotor static and dynamic imbalance as their force and torque on the bus
- faults.py           timed unit faults (`model.faults`) injected into the plant
- vscmg_allocator.py  the allocator `vscmg`: variable-speed rotors, Schaub-Junkins weighted steering
- stages.py           the open-loop allocator `gimbal_rate_profile`
- metrics.py          servo tracking of the held gimbal-rate command
"""

from testbed.systems.cmg_rhombus import metrics, reduced_model, stages, vscmg_allocator  # noqa: F401  (register)
from testbed.systems.cmg_rhombus.cluster import ClusterGeometry
from testbed.systems.cmg_rhombus.faults import check_fault_times
from testbed.systems.cmg_rhombus.model import MAX_DT_OVER_ROTOR_TAU, CmgRhombusParams, build
from testbed.systems.cmg_rhombus.plant import CmgPlant, CmgRhombus
from testbed.systems.registry import system


@system("cmg_rhombus", CmgRhombusParams)
def make_plant(params: CmgRhombusParams, sim) -> CmgPlant:
    check_fault_times(params.faults, sim.end_time_s - sim.control_period_s,  # the last tick
                      sim.dt_s / MAX_DT_OVER_ROTOR_TAU, sim.dt_s)
    return CmgPlant(build(params, sim.dt_s, sim.integrator), params, sim.control_period_s)


__all__ = ["ClusterGeometry", "CmgPlant", "CmgRhombus", "CmgRhombusParams", "build", "make_plant"]
