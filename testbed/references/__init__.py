"""Analytic and high-accuracy reference models, kept apart from the MuJoCo truth.

- ``torque_free``: closed-form (Jacobi-elliptic) body rates of a torque-free rigid body.
- ``gyrostat_ode``: DOP853 reference integration of a gyrostat, I w' + w x (I w + h) = -h'.
- ``reduced_cmg``: reduced model of a CMG-equipped spacecraft (its own module).
"""

from testbed.references.gyrostat_ode import gyrostat_energy, gyrostat_momentum, gyrostat_omega
from testbed.references.torque_free import (
    TorqueFreeSolution,
    jacobi_sncndn,
    solve_torque_free,
    torque_free_omega,
)

__all__ = [
    "TorqueFreeSolution",
    "gyrostat_energy",
    "gyrostat_momentum",
    "gyrostat_omega",
    "jacobi_sncndn",
    "solve_torque_free",
    "torque_free_omega",
]
