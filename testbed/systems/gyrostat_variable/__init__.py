"""Variable-structure gyrostat of Bezglasny & Khudyakova (seed 002): a carrier with a turning
rod and a coaxial rotor on prescribed motions, stabilised on a program motion
(models/gyrostat_variable.xml).

- model.py           `VariableGyrostatParams` (the `model:` block), shapes' inertias, `build`, the program r(t)
- plant.py           the carrier as a free bus, hinge servos, Euler-angle deviations
- program_motion.py  Lagrange dynamics in the Euler angles by MuJoCo inverse dynamics
- stages.py          law `computed_torque` (eqs. 3.1, 3.3, 3.4)
- metrics.py         the deviations x, x' and their decay envelope
"""

from testbed.systems.gyrostat_variable import metrics, stages  # noqa: F401  (register)
from testbed.systems.gyrostat_variable.model import VariableGyrostatParams, build
from testbed.systems.gyrostat_variable.plant import VariableGyrostatPlant
from testbed.systems.registry import system


@system("gyrostat_variable", VariableGyrostatParams)
def make_plant(params: VariableGyrostatParams, sim) -> VariableGyrostatPlant:
    return VariableGyrostatPlant(build(params, sim.dt_s, sim.integrator), params)


__all__ = ["VariableGyrostatParams", "VariableGyrostatPlant", "build", "make_plant"]
