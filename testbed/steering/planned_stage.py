"""The allocator `planned`: a gimbal path planned before the run for the slew law's momentum program,
tracked with exact torque (docs/theory/steering.md "Planned paths").

At construction it reads the `slew` law's program (its design data `slew_program`; rest to rest,
from a cluster holding no momentum, so the cluster must hold H_w(t) = -I omega*(t) in body axes,
I the locked inertia), plans the path (planned_path.plan_gimbal_path on the cluster's unit J) and
refuses the run (exit 2, before the first step) when the plan is refused or its reconfiguration
before the slew does not fit in start_s at the rate limit. In flight it runs the `pga` law with the
preferred angles moved along the plan: from the start to the plan's first angles over [0, start_s]
(the reconfiguration, linear), then the plan's angles one control period ahead, with the null gain
1 / Tc; the torque is the pseudo-inverse's, exact on the demand.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.errors import InputError
from testbed.guidance.slew import build_program
from testbed.pipeline import stage
from testbed.scenario.schema import param
from testbed.steering.planned_path import plan_gimbal_path
from testbed.steering.stage import SteeringAllocator, SteeringParams

TYPE = "pipeline.allocator.type"


@dataclass(kw_only=True)
class PlannedParams(SteeringParams):
    plan_step_s: float = param(0.5, gt=0, doc="step of the planned path")
    plan_evaluations: int = param(150, ge=1, le=10000, doc="most cost evaluations of the optimiser")


@stage("allocator", "planned", PlannedParams)
class PlannedAllocator(SteeringAllocator):
    """Pseudo-inverse rates with null motion along a gimbal path planned before the run for the slew
    law's momentum program (planned_path.py); refuses a program it cannot fly."""

    law_name = "pga"

    def __init__(self, params: PlannedParams, ctx):
        super().__init__(params, ctx)
        law = ctx.stages.get("law")
        program = None if law is None else law.design.get("slew_program")
        if program is None:
            raise InputError(TYPE, "planned steering needs the slew law (it plans for the slew's program)")
        if np.any(program.initial_rate_deg_s) or np.any(program.final_rate_deg_s) or np.any(ctx.initial.omega):
            raise InputError(TYPE, "planned steering plans rest-to-rest slews from rest")
        if np.linalg.norm(self.geometry.momentum(self.start)) > 1e-6 * self.geometry.h:
            raise InputError(TYPE, "planned steering needs a start holding no momentum (a zero-momentum set)")
        trajectory = build_program(program, ctx.initial.quat)
        inertia, h = np.asarray(ctx.inertia, float), self.geometry.h
        plan = plan_gimbal_path(self.geometry.unit_jacobian, self.start,
                                lambda t: -(inertia @ trajectory.acceleration(t)) / h, program.duration_s,
                                self.rate_max, plan_dt=params.plan_step_s, max_evaluations=params.plan_evaluations)
        if plan is None:
            raise InputError(TYPE, "no planned gimbal path flies this slew within the rate limit and "
                             "sqrt(det(J J^T)) >= 0.05; slow the slew down or shorten it")
        travel = float(np.abs(plan.angles[0] - self.start).max())
        if travel > 0 and travel > self.rate_max * program.start_s:
            raise InputError(TYPE, f"the planned start is {np.degrees(travel):.3g} deg away; start_s = "
                             f"{program.start_s:g} s is too short to reach it at the rate limit")
        self.plan, self.slew_start = plan, program.start_s
        self.options["null_gain_per_s"] = 1.0 / self.period

    def _inputs(self, t: float, beta: np.ndarray) -> dict:
        inputs = super()._inputs(t, beta)
        plan = getattr(self, "plan", None)
        if plan is not None:
            ahead = t + self.period
            if ahead < self.slew_start:  # the reconfiguration before the slew
                inputs["preferred_gimbal_angles"] = self.start + (plan.angles[0] - self.start) * ahead / self.slew_start
            else:
                inputs["preferred_gimbal_angles"] = plan.at(ahead - self.slew_start)
        return inputs
