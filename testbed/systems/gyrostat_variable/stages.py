"""Program motion of the variable-structure gyrostat and its stabilisation, as a control law
(Bezglasny & Khudyakova, seed 002, eqs. 3.1, 3.3, 3.4; program_motion.py).

`computed_torque` (law) reads the carrier's attitude and rate (sensor `ideal_attitude`,
estimator `attitude`), forms the Euler angles q, q' and the deviations x = q - r(t),
x' = q' - r'(t) from the program of `model` (gyrostat_variable), and returns the body torque

    tau = E(q)^-T Q,   Q = ID(t, q, q', r'') - 1/2 A'(t, q) x' - C x - D x',

ID = MuJoCo inverse dynamics in Euler coordinates on the law's own copy of the model, with
the rod and rotor on their known prescribed motion alpha(t), sigma(t) (the paper's known
functions of time). Recorded besides: the program force Q_p = ID(t, r, r', r'') (3.1),
the stabilising force Q_s = Q - Q_p (3.4), x and x'. C and D are generalised stiffness
and damping on the Euler angles [N m/rad, N m s/rad] (paper: C = 100 E, D = 500 E).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.errors import InputError
from testbed.math.euler_angles import angle_rates, euler_from_quat
from testbed.math.validation import check_positive_definite
from testbed.pipeline import stage
from testbed.scenario.schema import join, param
from testbed.systems.gyrostat_variable.model import build, deviations, prescribed, program
from testbed.systems.gyrostat_variable.program_motion import EulerDynamics

IDENTITY = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]


@dataclass(kw_only=True)
class ComputedTorqueParams:
    stiffness_nm_rad: list[list[float]] = param([[100.0 * v for v in row] for row in IDENTITY], length=3,
                                                doc="C of (3.3), (3.4): symmetric positive definite")
    damping_nms_rad: list[list[float]] = param([[500.0 * v for v in row] for row in IDENTITY], length=3,
                                               doc="D of (3.4): positive definite")

    def validate(self, path: str) -> None:
        check_positive_definite(self.stiffness_nm_rad, join(path, "stiffness_nm_rad"), symmetric=True)
        check_positive_definite(self.damping_nms_rad, join(path, "damping_nms_rad"), symmetric=False)


@stage("law", "computed_torque", ComputedTorqueParams)
class ComputedTorque:
    def __init__(self, params: ComputedTorqueParams, ctx):
        if ctx.system != "gyrostat_variable":
            raise InputError("pipeline.law.type", "computed_torque needs model.system gyrostat_variable")
        if not {"quat", "omega"} <= ctx.stages["estimator"].outputs:
            raise InputError("pipeline.estimator.type", "computed_torque needs the carrier's quat and omega "
                             "(sensor ideal_attitude, estimator attitude)")
        self.model_params = ctx.model
        self.dynamics = EulerDynamics(build(ctx.model, ctx.dt, ctx.integrator))
        self.C = np.asarray(params.stiffness_nm_rad, float)
        self.D = np.asarray(params.damping_nms_rad, float)

    def torque(self, t, estimate):
        q = euler_from_quat(estimate["quat"])
        qd = angle_rates(q, estimate["omega"])
        r, rd, rdd = program(self.model_params, t)
        x, xd = deviations(self.model_params, t, q, qd)
        ref = prescribed(t, self.model_params)
        hinge, hinge_rate = [ref["rod_angle"], ref["rotor_angle"]], [ref["rod_rate"], ref["rotor_rate"]]
        dyn = self.dynamics
        program_force = dyn.generalised_force(r, dyn.inverse(r, rd, rdd, hinge, hinge_rate))      # (3.1)
        feedforward = dyn.generalised_force(q, dyn.inverse(q, qd, rdd, hinge, hinge_rate))
        a_dot = dyn.mass_matrix_rate(q, qd, hinge, hinge_rate)
        force = feedforward - 0.5 * a_dot @ xd - self.C @ x - self.D @ xd
        return {"torque": dyn.body_torque(q, force), "program_force": program_force,
                "stabilising_force": force - program_force, "deviation": x, "deviation_rate": xd}

