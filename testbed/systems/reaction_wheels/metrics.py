"""Metrics of reaction-wheel runs: how much of the wheels' momentum and torque the run used.

Each is a running reduction (testbed.recording.reductions) or an allocator statistic: a run keeps
no signal's history for them.
"""

from __future__ import annotations

import math

import numpy as np

from testbed.metrics import metric
from testbed.recording.reductions import NanMaxBefore
from testbed.systems.reaction_wheels.wheel_array import WheelArray


def _wheels(scenario) -> bool:
    """A bus with wheels: the reaction_wheels system, or a CMG cluster with `model.wheels` (a hybrid bus)."""
    return scenario.system == "reaction_wheels" or (scenario.system == "cmg_cluster"
                                                    and scenario.model.wheels is not None)


WHEEL_ALLOCATORS = {"wheel_pinv": "min_scale", "wheel_minimax": "min_scale", "hybrid_split": "min_wheel_scale"}


def _allocated(scenario) -> bool:
    return _wheels(scenario) and scenario.stages["allocator"][0] in WHEEL_ALLOCATORS


def _array(run) -> WheelArray:
    """The wheel array of the run's plant description: the array itself, or a hybrid bus's wheels."""
    return run.description if isinstance(run.description, WheelArray) else run.description.wheels


def _absolute(key: str):
    def rows(chunk):
        values = chunk.signals.get(key)
        return None if values is None else np.abs(values)

    return rows


_speed_rows, _torque_rows = _absolute("truth/wheel_rate"), _absolute("truth/wheel_torque")
SPEED_PEAK = NanMaxBefore(_speed_rows, math.inf)  # per wheel max |Omega_i| over the run
TORQUE_PEAK = NanMaxBefore(_torque_rows, math.inf)  # per wheel max |u_i|


@metric("peak_wheel_momentum_fraction", applies=_wheels, uses=(SPEED_PEAK,))
def peak_wheel_momentum_fraction(run) -> float:
    """max over samples and wheels of |h_i| / (Js_i Omega_max,i) = |Omega_i| / Omega_max,i: the share of
    each wheel's momentum saturation used (1: a wheel at its speed limit)."""
    return float(np.max(run.reduced(SPEED_PEAK) / _array(run).speed_max))


@metric("peak_wheel_torque_fraction", applies=_wheels, uses=(TORQUE_PEAK,))
def peak_wheel_torque_fraction(run) -> float:
    """max over samples and wheels of the motor torque applied |u_i| / u_max,i (1: a motor at its limit)."""
    return float(np.max(run.reduced(TORQUE_PEAK) / _array(run).torque_max))


@metric("min_wheel_scale", applies=_allocated, uses=())
def min_wheel_scale(run) -> float:
    """Smallest factor over every control step by which the allocator scaled the command to the wheels'
    torque and speed limits (1: never limited)."""
    return float(run.statistics["allocator"][WHEEL_ALLOCATORS[run.scenario.stages["allocator"][0]]])
