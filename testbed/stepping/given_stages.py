"""Python objects in the pipeline's slots: a stage the caller built (or a function), and one
step's command given outright, held to the output checks a plug-in stage is held to
(testbed.run_core.output_check.OutputCheck). docs/stepping.md "Python objects as stages"."""

from __future__ import annotations

import inspect

from testbed.errors import InputError
from testbed.run_core.output_check import INTERFACE_SHAPES, OutputCheck
from testbed.run_core.stage_contract import SLOTS, Declared

# the method each slot's Protocol calls (testbed.run_core.stage_contract: Sensor, Estimator, Law, Allocator)
SLOT_METHODS = {"sensor": "measure", "estimator": "estimate", "law": "torque", "allocator": "allocate"}


class FunctionStage:
    """A plain function as a stage: `function(t, ...)` called as the slot's method, with the
    slot's arguments (a law's `torque(t, estimate)`, ...)."""

    def __init__(self, slot: str, function, output: str | None = None):
        self.type_name = getattr(function, "__qualname__", type(function).__name__)
        if output is not None:
            self.output = output
        setattr(self, SLOT_METHODS[slot], function)


class GivenMapping(dict):
    """A given output that names itself when the stage after it reads a key it lacks: the
    failure is that stage's (its run ends like any stage's), the reason the caller's."""

    def __init__(self, slot: str, output: dict):
        super().__init__(output)
        self.slot = slot

    def __missing__(self, key):
        raise KeyError(f"{key!r}, which the {self.slot} output given to Simulation.step lacks")

    def __or__(self, other):  # the law's input with the internal momentum added stays one
        return GivenMapping(self.slot, {**self, **other})


class GivenOutput:
    """A stage that returns one fixed output: a command given for one step
    (`testbed.stepping.Simulation.step`)."""

    type_name = "given"

    def __init__(self, slot: str, output: dict, command_key: str | None = None):
        self.output = command_key
        given = GivenMapping(slot, output)
        setattr(self, SLOT_METHODS[slot], lambda *args: given)


def given_stage(slot: str, stage_object, actuators: dict, configured_output: str | None = None,
                field: str = "stages"):
    """(stage, OutputCheck) for `stage_object` in `slot`: an object with the slot's method
    (and, for an allocator, `output`: the command key, one of the plant's `actuators`), or a
    function called as that method (an allocator function commands `configured_output`, the
    configured allocator's key). Anything else is refused (InputError naming `field.slot`)."""
    where = f"{field}.{slot}"
    if slot not in SLOTS:
        raise InputError(f"{field}", f"unknown slot {slot!r} (known: {', '.join(SLOTS)})")
    method = SLOT_METHODS[slot]
    if inspect.isclass(stage_object):
        raise InputError(where, f"got the class {stage_object.__name__}: pass an instance (with a "
                                f"{method} method) or a function")
    if callable(getattr(stage_object, method, None)):
        stage = stage_object
    elif callable(stage_object):
        stage = FunctionStage(slot, stage_object, configured_output if slot == "allocator" else None)
    else:
        raise InputError(where, f"{type(stage_object).__name__} has no {method} method and is not a function")
    declared = Declared.of(stage)
    return stage, output_check(slot, type_of_given(stage), actuators, declared.output, declared.outputs or (), where)


def output_check(slot: str, name: str, actuators: dict, output: str | None = None, required=(),
                 where: str = "stages") -> OutputCheck:
    """The check a plug-in stage of `slot` gets (testbed.run_core.tick.Pipeline.from_config): the
    `required` keys, the slot's interface shapes and, for an allocator, its command key `output`
    with the shape the plant's `actuators` take."""
    shapes = dict(INTERFACE_SHAPES.get(slot, {}))
    required = tuple(required)
    if slot == "allocator":
        if not isinstance(output, str) or output not in actuators:
            raise InputError(where, f"an allocator names its command key in `output`, one of "
                                    f"{sorted(actuators)}; got {output!r}")
        required += (output,)
        shapes[output] = actuators[output]
    return OutputCheck(slot, name, required, shapes)


def type_of_given(stage_object) -> str:
    """What the run summary calls a Python object's stage: its `type_name`, else its class's name."""
    return str(Declared.of(stage_object).type_name or type(stage_object).__qualname__)
