"""A rigid bus with a full inertia tensor and an array of reaction wheels (models/reaction_wheels.xml).

- wheel_array.py   the presets' spin axes and `WheelArray`, what the allocator knows of the array
- model.py         `ReactionWheelsParams` (the `model:` block) and `build` through MjSpec
- plant.py         the wheels' hinges and motors; the plant the runner steps
- allocator.py     the allocator `wheel_pinv`: minimum-norm wheel torques, saturation, null-space management
- minimax_allocation.py  the allocator `wheel_minimax`: the least largest wheel torque (an LP)
- metrics.py       wheel momentum and torque use

Theory and validation: docs/theory/reaction-wheels.md.
"""

from testbed.systems.reaction_wheels import allocator, metrics, minimax_allocation  # noqa: F401  (register)
from testbed.systems.reaction_wheels.model import ReactionWheelsParams, build
from testbed.systems.reaction_wheels.plant import ReactionWheelPlant
from testbed.systems.registry import system


@system("reaction_wheels", ReactionWheelsParams)
def make_plant(params: ReactionWheelsParams, sim) -> ReactionWheelPlant:
    return ReactionWheelPlant(build(params, sim.dt_s, sim.integrator), params)


__all__ = ["ReactionWheelPlant", "ReactionWheelsParams", "build", "make_plant"]
