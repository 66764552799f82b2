"""The checks a stage from outside the package (a plug-in, a Python object) is held to at every tick."""

from __future__ import annotations

import numpy as np

from testbed.errors import quoted
from testbed.run_core.stage_contract import StageFailed


# Keys whose shape the slot's interface fixes (testbed.run_core.stage_contract); a command key's shape
# comes from the plant (`Plant.actuators`).
INTERFACE_SHAPES = {"law": {"torque": (3,)}}


class OutputCheck:
    """Checks one stage's output at every tick: a dict with its declared `outputs` keys, each a
    finite real array whose shape is the interface's, or else the one it had at the first tick.
    Applied to stages from outside the package (plug-ins); the built-ins are tested instead."""

    def __init__(self, slot: str, name: str, required=(), shapes: dict | None = None):
        # the slot's interface keys are required whatever the stage declares (a law's `torque`:
        # a law without it would leave the allocator no demand, and the run would pass on none)
        self.slot, self.name = slot, name
        self.required = tuple(dict.fromkeys((*required, *INTERFACE_SHAPES.get(slot, {}))))
        self.shapes = dict(shapes or {})

    def __call__(self, t: float, out) -> None:
        if not isinstance(out, dict):
            raise StageFailed(t, self.slot, self.name, f"returned {type(out).__name__}, not a dict of arrays")
        for key in self.required:
            if key not in out:
                raise StageFailed(t, self.slot, self.name, f"missing key {key!r} (a {self.slot} returns "
                                  f"{', '.join(map(repr, self.required))})")
        for key, value in out.items():
            try:
                array = np.asarray(value)
                kind = array.dtype.kind
                if kind != "f":
                    if kind == "c":  # float() of it would drop the imaginary part
                        raise StageFailed(t, self.slot, self.name, f"returned a complex {key!r}: {quoted(value)}")
                    if kind not in "biuO":  # text, dates: not numbers, though float() may read them
                        raise TypeError
                    array = array.astype(float)
            except (TypeError, ValueError, OverflowError):
                raise StageFailed(t, self.slot, self.name, f"key {key!r} is not numeric: {quoted(value)}") from None
            expected = self.shapes.setdefault(key, array.shape)
            if array.shape != expected:
                raise StageFailed(t, self.slot, self.name, f"key {key!r} has shape {array.shape}, expected {expected}")
            if not np.all(np.isfinite(array)):
                raise StageFailed(t, self.slot, self.name, f"key {key!r} is not finite: {array.tolist()}")
