"""Which quantities a run conserves: the one rule behind the drift metrics, the plant's energy
record and the accuracy guard's conservation monitors (docs/theory/accuracy.md).

The scenario decides what can be conserved before anything is built (`Conservation.of`: the
metrics `momentum_drift_rel` and `energy_drift_rel` exist only there); the built plant decides
at the end of the run whether its physics kept it (`Conservation.kept_by`: no external wrench at
any step, and for the energy no actuator that works and no friction).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco

from testbed.appendages.params import has_appendages
from testbed.run_core.stage_registry import output_of
from testbed.systems.registry import is_free_flying


def no_feedback_actuator(model) -> bool:
    """Whether every actuator of the compiled model is a plain motor (no bias term): with nothing
    commanded it gives no force, so nothing works on the system. A servo (a position or
    velocity loop, MuJoCo's bias) holds its set-point and works against what moves it."""
    return all(int(b) == mujoco.mjtBias.mjBIAS_NONE for b in model.actuator_biastype)


def frictionless(model) -> bool:
    """Whether no joint of the compiled model has friction (damping or frictionloss): friction
    between two bodies is internal, it keeps the momentum but takes energy away."""
    return not (model.dof_damping.any() or model.dof_frictionloss.any())


def springless(model) -> bool:
    """Whether no joint of the compiled model has a spring (a panel hinge, a slosh slide): a
    spring stores energy, so the kinetic energy alone is not conserved."""
    return not model.jnt_stiffness.any()


@dataclass(frozen=True)
class Conservation:
    """momentum: the total angular momentum can be conserved (a free body whose actuators are all
    internal: no ideal external torque, no environment torque); energy: the kinetic energy can
    be conserved (no allocator commands anything, no environment, and no appendage's spring or
    damper trades energy)."""

    momentum: bool
    energy: bool

    @classmethod
    def of(cls, scenario) -> "Conservation":
        allocator = scenario.stages["allocator"][0]
        free = scenario.environment is None
        return cls(momentum=free and is_free_flying(scenario) and output_of("allocator", allocator) != "body_torque",
                   energy=free and allocator == "none" and not has_appendages(scenario))

    def kept_by(self, plant) -> "Conservation":
        """What the run's physics conserved, read once it ran: a body torque given at any step (a
        Python allocator's, a stepped run's command) breaks momentum conservation as much as a
        configured one (`Plant.external_wrench`); the energy also needs `no_feedback_actuator`,
        `frictionless` and `springless`."""
        if plant.external_wrench():
            return Conservation(False, False)
        return Conservation(self.momentum, self.energy and no_feedback_actuator(plant.model)
                            and frictionless(plant.model) and springless(plant.model))
