"""A run's plan: everything decided before its first step, made once by `prepare(scenario)`.

The plant, the pipeline and the reference are built (every design-time check happens here),
and the timing, the signals and reductions to keep, the conservation rule and the accuracy
guard's monitors are read off the scenario and what was built. A run (testbed.run_core.in_progress),
a stepped `Simulation`, a campaign case and a Gymnasium environment all start from a plan.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed import metrics
from testbed.accuracy.guard import Monitors
from testbed.accuracy.step_size import refuse_unresolved_step
from testbed.environment import surroundings
from testbed.errors import InputError, refused_as
from testbed.run_core.stage_contract import StageContext
from testbed.run_core.stage_registry import stage_infos
from testbed.run_core.tick import Pipeline
from testbed.references import registry as references_registry
from testbed.run_core.conservation import Conservation
from testbed.run_core.timing import Timing
from testbed.stepping.given_stages import given_stage, type_of_given
from testbed.systems import registry as systems_registry


@dataclass(frozen=True)
class RunPlan:
    """What a run of `scenario` is made of, fixed before its first step.

    plant, pipeline, reference: built at t = 0 (`reference` None without a `reference:` block);
    timing: the periods and counts (testbed.run_core.timing); kept_signals: the signal keys whose
    whole history the metrics and the reference read (None: every signal); reductions: the
    running reductions the metrics and the accuracy guard read; conservation: what the physics
    can conserve; monitors: the accuracy guard's; given_types: slot -> the type name of each
    Python object given as a stage (`stages=`), for the run summary."""

    scenario: object
    plant: object
    pipeline: Pipeline
    reference: object
    timing: Timing
    kept_signals: frozenset | None
    reductions: tuple
    conservation: Conservation
    monitors: Monitors
    given_types: dict

    def with_stages(self, stages: dict) -> "RunPlan":
        """This plan with each Python object of `stages` (slot -> object) in its slot
        (`install_stages`), its monitors read again from the stages now in place."""
        install_stages(self.pipeline, self.plant, stages)  # into the one pipeline both plans hold
        return _planned(self.scenario, self.plant, self.pipeline, self.reference, self.timing,
                        self.given_types | _given_types(self.pipeline, stages))


def prepare(scenario, stages: dict | None = None, stepped: bool = False) -> RunPlan:
    """Build the plant, the pipeline and the reference, and plan the run: every design-time check
    happens here. `stages`: slot -> a Python object (or function) that takes that slot's place in
    the pipeline, checked like a plug-in (`install_stages`); `stepped`: a run stepped from Python
    (testbed.stepping), which may give the allocator's command at each step.

    Parameters so extreme that building from them overflows or breaks a factorisation are bad
    input, named by the part being built (model, pipeline slot, reference)."""
    given = scenario  # what the run reports on; built from:
    scenario = surroundings.in_orbit(scenario)  # an initial state given in LVLH, in ECI
    timing = Timing.of(scenario.sim)
    built_from = {"model": scenario.model, "initial": scenario.initial, "orbit": scenario.orbit,
                  "environment": scenario.environment}
    with np.errstate(all="raise"), refused_as("model", params=built_from):
        plant = systems_registry.make_plant(scenario)
        plant.record_energy = Conservation.of(scenario).energy
        plant.initialise(scenario.initial)
        plant.surroundings = surroundings.prepare(scenario, plant)
        ctx = stage_context(scenario, plant.locked_inertia(), plant.description(), plant.actuator_state(),
                            plant.internal_momentum_body())
    refuse_unresolved_step(scenario, plant, timing.dt_s)  # the accuracy guard's step-size check, before the stages
    with np.errstate(all="raise"):
        pipeline = Pipeline.from_config(scenario.stages, ctx, plant.actuators)
    output = pipeline.declared["allocator"].output
    if output is not None and output not in plant.actuators:
        raise InputError("pipeline.allocator.type", f"{scenario.stages['allocator'][0]} commands {output}, "
                         f"which model.system {scenario.system} does not have")
    if stages:
        install_stages(pipeline, plant, stages)
    if not stepped:
        refuse_a_lost_law_output(scenario, stages or {})
    references_registry.check_system(scenario)  # after the stages: a reference describes them
    reference_params = {"reference": scenario.reference[1]} if scenario.reference else {}
    with np.errstate(all="raise"), refused_as("reference", params=reference_params):
        reference = references_registry.prepare(scenario, plant) if scenario.reference else None
    return _planned(given, plant, pipeline, reference, timing, _given_types(pipeline, stages or {}))


def refuse_a_lost_law_output(scenario, stages: dict) -> None:
    """A law without an allocator is refused: the plant takes only the allocator's command, so
    the law's torque would never reach it and the run would fly open loop without a word."""
    law = "law" in stages or scenario.stages["law"][0] != "none"
    allocator = "allocator" in stages or scenario.stages["allocator"][0] != "none"
    if law and not allocator:
        raise InputError("pipeline.allocator", "none applies no command, so the law's torque would never reach "
                         "the plant: give an allocator (ideal_torque applies the torque as asked)")


def _given_types(pipeline, stages: dict) -> dict:
    return {slot: type_of_given(pipeline.stages()[slot]) for slot in stages}


def _planned(scenario, plant, pipeline, reference, timing: Timing, given_types: dict) -> RunPlan:
    """The plan of a run of what was built: what it keeps, reduces and monitors."""
    keep = metrics.kept_signals(scenario)
    declared = references_registry.DeclaredReference.of(reference)
    if reference is not None and not declared.streaming and keep is not None:
        # a reference evaluated on the whole run reads the kept history; one that does not say what it reads, all of it
        keep = None if declared.signals is None else keep | set(declared.signals) | {"truth/omega"}
    conservation = Conservation.of(scenario)
    monitors = Monitors(scenario, plant, pipeline.declared["allocator"].output, conservation, timing.dt_s)
    return RunPlan(scenario, plant, pipeline, reference, timing,
                   None if keep is None else frozenset(keep),
                   tuple(metrics.reductions(scenario) + monitors.reductions()), conservation, monitors, given_types)


def install_stages(pipeline, plant, stages: dict) -> None:
    """Put each Python object of `stages` (slot -> object) in its slot of `pipeline`, in place
    of the configured stage, with a plug-in's output checks (testbed.stepping.given_stages)."""
    if not isinstance(stages, dict):
        raise InputError("stages", f"must be a mapping of slot -> object, got {type(stages).__name__}")
    for slot, stage_object in stages.items():
        configured = pipeline.declared["allocator"].output if slot == "allocator" else None
        pipeline.set_stage(slot, *given_stage(slot, stage_object, plant.actuators, configured))


def stage_context(scenario, inertia, description=None, actuators=None, internal_momentum=None) -> StageContext:
    """What the stages of `scenario` may know at construction (testbed.run_core.stage_contract.StageContext);
    `actuators`: the plant's actuator read-outs at t = 0, `internal_momentum` its H(0)."""
    sim = scenario.sim
    timing = Timing.of(sim)  # (a stage built outside a run, e.g. in a test, has no plan)
    return StageContext(dt=timing.dt_s, control_period=timing.control_period_s, sample_period=timing.sample_period_s,
                        inertia=inertia,
                        internal_momentum=np.zeros(3) if internal_momentum is None else internal_momentum,
                        description=description, system=scenario.system, model=scenario.model,
                        free_flying=systems_registry.is_free_flying(scenario),
                        initial=scenario.initial, integrator=sim.integrator,
                        end_time=timing.n_ticks * timing.control_period_s,
                        stages=stage_infos(scenario.stages), actuators=dict(actuators or {}),
                        orbit=scenario.orbit)

