"""The step-size check: the fastest rates of the model against what RK4 resolves at the step dt.

A rate w turns w dt rad in one step; RK4's amplification of a rotation at w dt has a phase
error of (w dt)^5 / 120 and a gain error of (w dt)^6 / 144 a step (docs/theory/accuracy.md).
"""

from __future__ import annotations

import numpy as np

from testbed.errors import InputError

BUS_RATE = "bus rate"


def known_rates(scenario, plant) -> dict[str, float]:
    """The model's rates [rad/s] known before the first step: the bus rate at t = 0 and what the
    plant lists in `step_rates()` (testbed.plant.Plant)."""
    rates = {BUS_RATE: float(np.linalg.norm(scenario.initial.omega))}
    rates.update(plant.step_rates())
    return rates


def refuse_unresolved_step(scenario, plant, dt: float) -> None:
    """InputError on sim.dt_s when a rate known before the run turns more than the guard's
    step_angle_max_rad in one physics step of `dt` [s] (nothing is run)."""
    guard = scenario.accuracy
    if not guard.enabled:
        return
    for name, rate in known_rates(scenario, plant).items():
        angle = rate * dt
        if angle > guard.step_angle_max_rad:
            raise InputError("sim.dt_s", f"{dt:g} s turns the {name} of {rate:.3g} rad/s by {angle:.3g} rad a step; "
                             f"RK4 resolves at most accuracy.step_angle_max_rad = {guard.step_angle_max_rad:g} rad: "
                             f"use dt_s <= {guard.step_angle_max_rad / rate:.3g} s")
