"""Open-loop stages: no sensor, no estimator, prescribed torque or gimbal-rate profiles.

They let a validation scenario drive the plant without any controller: `torque_profile`
(a law) with the `ideal_torque` allocator applies M(t) = M0 + A sin(2 pi f t + phi) on the
bus. `SinusoidProfile` is the schema of such a profile; a system's own open-loop stages
reuse it for their actuators.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import sin

import numpy as np

from testbed.batch.stacked_stages import StatelessForm

from testbed.pipeline import stage
from testbed.scenario.schema import param

ZERO3 = [0.0, 0.0, 0.0]


class _EmptySlot:
    """A slot left empty: it takes no parameters and returns nothing (so the pipeline does not
    call it: `returns_nothing`)."""

    returns_nothing = True

    def __init__(self, params, ctx):
        pass

    def _nothing(self, *inputs) -> dict:
        return {}


# the four slots' methods (testbed.pipeline): each empty stage answers its own with nothing
for _slot, _method in (("sensor", "measure"), ("estimator", "estimate"), ("law", "torque"),
                       ("allocator", "allocate")):
    stage(_slot, "none")(type(f"No{_slot.title()}", (_EmptySlot,), {_method: _EmptySlot._nothing}))


@dataclass
class SinusoidProfile:
    """x(t) = offset + amplitude sin(2 pi frequency t + phase), per component, inside [start, stop)."""

    offset: list[float] = param(ZERO3)
    amplitude: list[float] = param(ZERO3)
    frequency_hz: list[float] = param(ZERO3, ge=0)
    phase_deg: list[float] = param(ZERO3)
    start_s: float = param(0.0, ge=0)
    stop_s: float | None = param(None, ge=0)

    def validate(self, path: str) -> None:
        from testbed.errors import InputError

        n = {len(self.offset), len(self.amplitude), len(self.frequency_hz), len(self.phase_deg)}
        if len(n) != 1:
            raise InputError(path, "offset, amplitude, frequency_hz and phase_deg must have equal lengths")
        if self.stop_s is not None and self.stop_s <= self.start_s:
            raise InputError(f"{path}.stop_s", f"must be > start_s = {self.start_s:g}")
        # (offset, amplitude, 2 pi f, phase [rad]) per component, as plain floats: a few
        # components cost less in Python arithmetic than in numpy's calls
        self._terms = list(zip(np.array(self.offset, float).tolist(), np.array(self.amplitude, float).tolist(),
                               (2 * np.pi * np.array(self.frequency_hz)).tolist(),
                               np.deg2rad(self.phase_deg).tolist()))

    def __call__(self, t: float) -> np.ndarray:
        return np.array(self.values(t))

    def values(self, t: float) -> list[float]:
        """x(t) as a list of plain floats (for a command handed on every control tick)."""
        if t < self.start_s or (self.stop_s is not None and t >= self.stop_s):
            return [0.0] * len(self._terms)
        values = []
        for offset, amplitude, omega, phase in self._terms:  # a loop: cheaper than a comprehension
            values.append(offset + amplitude * sin(omega * t + phase))
        return values


@dataclass
class TorqueProfileParams(SinusoidProfile):
    """Body torque [N m], body axes."""


@stage("law", "torque_profile", TorqueProfileParams)
class TorqueProfile:
    def __init__(self, params, ctx):
        self.profile = params

    def torque(self, t, estimate):
        return {"torque": self.profile(t)}


@stage("allocator", "ideal_torque")
class IdealTorque:
    """Applies the demanded torque exactly on the bus (torque motors on its centre site)."""

    output = "body_torque"

    @classmethod
    def design(cls, params) -> dict:
        return {"delivered_torque": "body_torque"}

    def __init__(self, params, ctx):
        pass

    @classmethod
    def batched(cls, stages: list) -> StatelessForm:
        return StatelessForm(stages, "allocator", ())

    def allocate(self, t, demand, estimate, actuators):
        return {"body_torque": np.asarray(demand.get("torque", np.zeros(3)), float)}
