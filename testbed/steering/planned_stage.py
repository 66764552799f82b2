"""The allocator `planned`: a gimbal path planned before the run for the slew law's momentum program,
tracked with exact torque (docs/theory/steering.md "Planned paths").

At construction it reads the `slew` law's program (its design data `slew_program`; rest to rest,
from a cluster holding no momentum, so the cluster must hold H_w(t) = -I omega*(t) in body axes,
I the locked inertia: for the eigen-axis slew a line, H_w = s(t) d), plans the path
(planned_path.plan_gimbal_path on the cluster's unit H and J, its reconfiguration at rest within
start_s at the rate limit) and refuses the run (exit 2, before the first step) when the program
is not along one line or the plan is refused, saying why (planned_path.Refusal) and how much
slower the slew would plan. In flight it runs the `pga` law with the preferred
angles moved along the plan: along the reconfiguration over [0, start_s], then the plan's angles
one control period ahead, with the null gain 1 / Tc; the torque is the pseudo-inverse's, exact on
the demand.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.errors import InputError
from testbed.guidance.slew import build_program
from testbed.pipeline import stage
from testbed.scenario.schema import join, param
from testbed.steering.planned_path import PLAN_WORK_LIMIT, REFINEMENTS, PlannedPath, plan_gimbal_path, planning_work
from testbed.steering.stage import SteeringAllocator, SteeringParams

TYPE = "pipeline.allocator.type"
PATH = "pipeline.allocator"
SMALLEST_PROGRAM = 1e-9  # [h] peak momentum of a program below which there is nothing to plan
MAX_PLAN_STEPS = 10_000  # the program is sampled this often at most (0.2 ms a sample, measured)
# A refused slew is planned again slowed down by these factors (one pass each, unrefined), and the
# first that plans is named in the refusal: H_w = -I w scales as 1 / T, its rate as 1 / T^2.
SLOWER = (1.25, 1.5, 2.0)


@dataclass(kw_only=True)
class PlannedParams(SteeringParams):
    plan_step_s: float = param(0.1, gt=0, doc="time step of the planned path")
    plan_levels: int = param(60, ge=4, le=1000, doc="momentum levels of the planning graph")
    plan_spacing_deg: float = param(3.0, gt=0, le=30, doc="spacing of the samples along each fibre")

    def validate(self, path: str) -> None:
        super().validate(path)
        work = planning_work(self.plan_levels, np.radians(self.plan_spacing_deg))
        if work > PLAN_WORK_LIMIT:
            raise InputError(join(path, "plan_levels"), f"{self.plan_levels} levels of samples "
                             f"{self.plan_spacing_deg:g} deg apart bound the planner's work at {work:.3g}, "
                             f"over its limit {PLAN_WORK_LIMIT:.3g}: fewer levels or a wider spacing")


@stage("allocator", "planned", PlannedParams)
class PlannedAllocator(SteeringAllocator):
    """Pseudo-inverse rates with null motion along a gimbal path planned before the run for the slew
    law's momentum program (planned_path.py); refuses a program it cannot fly."""

    law_name = "pga"
    four_units_only = "it plans along the one-dimensional fibres H(beta) = s d of 4 units"

    @classmethod
    def stage_name(cls) -> str:
        return "planned"

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
        steps = trajectory.end / params.plan_step_s  # a shaped slew lasts the shaper's time longer
        if steps > MAX_PLAN_STEPS:
            raise InputError(join(PATH, "plan_step_s"), f"samples the {trajectory.end:g} s slew in {steps:.3g} "
                             f"steps, over the limit {MAX_PLAN_STEPS}: a plan step of at least "
                             f"{trajectory.end / MAX_PLAN_STEPS:.3g} s")
        inertia, h = np.asarray(ctx.inertia, float), self.geometry.h
        times = np.linspace(0.0, trajectory.end, max(2, int(np.ceil(steps)) + 1))
        wanted = -np.array([inertia @ trajectory.rate(t) for t in times]) / h
        peak = wanted[np.argmax(np.linalg.norm(wanted, axis=-1))]
        if not np.linalg.norm(peak) > SMALLEST_PROGRAM:  # a zero slew: no line, no levels to plan between
            raise InputError("pipeline.law.angle_deg", f"the slew asks the cluster for {np.linalg.norm(peak):.3g} h "
                             f"at most; planned steering plans slews asking for more than {SMALLEST_PROGRAM:g} h")
        direction = peak / max(np.linalg.norm(peak), 1e-300)
        levels = wanted @ direction
        off_line = max(np.abs(wanted - levels[:, None] * direction).max(), -levels.min())  # round-off for a line
        if off_line > 1e-9 * max(levels.max(), 1e-300):
            raise InputError(TYPE, "planned steering plans momentum programs along one line (eigen-axis slews)")
        def plan_for(slower: float, refinements=REFINEMENTS):
            # the same slew `slower` times longer: its program at times * slower, its momentum / slower
            return plan_gimbal_path(lambda beta: self.geometry.momentum(beta) / h, self.geometry.unit_jacobian,
                                    self.start, direction, times * slower, np.maximum(levels, 0.0) / slower,
                                    self.rate_max, reconfiguration_travel=self.rate_max * program.start_s,
                                    levels=params.plan_levels, spacing=np.radians(params.plan_spacing_deg),
                                    refinements=refinements)

        plan = plan_for(1.0)
        if not isinstance(plan, PlannedPath):
            slower = next((k for k in SLOWER if isinstance(plan_for(k, (1,)), PlannedPath)), None)
            advice = (f"slowed to {slower * program.duration_s:.3g} s (duration_s) it plans" if slower is not None
                      else f"it does not plan even slowed to {SLOWER[-1] * program.duration_s:.3g} s: shorten it")
            raise InputError(TYPE, f"no planned gimbal path flies this slew: {plan.reason()}; {advice}")
        self.plan, self.slew_start = plan, program.start_s
        self.options["null_gain_per_s"] = 1.0 / self.period

    def _inputs(self, t: float, beta: np.ndarray) -> dict:
        inputs = super()._inputs(t, beta)
        plan = getattr(self, "plan", None)
        if plan is not None:
            ahead = t + self.period
            if ahead < self.slew_start:  # the reconfiguration at rest before the slew
                inputs["preferred_gimbal_angles"] = plan.reconfigured_at(ahead / self.slew_start)
            else:
                inputs["preferred_gimbal_angles"] = plan.at(ahead - self.slew_start)
        return inputs
