"""The plants of a batch's live worlds: read, commanded and stepped together.

`PerWorldPlants` does it world by world, as each world's run would; a plant class may give a
faster form on (N, ...) arrays by overriding `Plant.group` (the same numbers to round-off).
Every method that may fail for one world raises `WorldsFailed` naming it, with the others' values.
"""

from __future__ import annotations

import numpy as np

from testbed.batch.stage_forms import WorldsFailed, nan_like, rows_of, stacked
from testbed.plant import SimulationDiverged


class PerWorldPlants:
    """The live worlds' plants, one by one. `plants`: one per live world, in order; `steps`: the
    physics steps of one control tick."""

    def __init__(self, plants: list, steps: int):
        self.plants = list(plants)
        self.steppers = [plant.stepper(steps) for plant in self.plants]

    def keep(self, rows: np.ndarray) -> None:
        """Only the worlds at `rows` (indices of the current rows) go on."""
        self.plants = [self.plants[i] for i in rows]
        self.steppers = [self.steppers[i] for i in rows]

    def settle(self, row: int) -> None:
        """Nothing to write back: each world's plant is its own (a group whose rows hold a plant's
        state writes it back into row's plant here, before its run's last truth sample)."""

    def _each(self, read, fill, combine):
        """combine([read(plant) of every live world]); a world whose read-outs overflow (its state
        blew up) fails, its row filled by `fill(a live world's value)`."""
        values, failures = [], {}
        for row, plant in enumerate(self.plants):
            try:
                values.append(read(plant))
            except FloatingPointError as exc:
                failures[row] = exc
                values.append(None)
        if failures:
            alive = next((v for v in values if v is not None), None)
            raise WorldsFailed(failures, combine([fill(alive) if v is None else v for v in values]))
        return combine(values)

    def truth(self) -> dict:
        """Each world's `Plant.truth()`, stacked (N, ...)."""
        return self._each(lambda plant: plant.truth(), nan_like, stacked)

    def actuator_state(self) -> dict:
        """Each world's `Plant.actuator_state()`, stacked (N, ...)."""
        return self._each(lambda plant: plant.actuator_state(), nan_like, stacked)

    def internal_momentum_body(self) -> np.ndarray:
        """Each world's momentum of its moving parts, body frame, (N, 3) [N m s]."""
        return self._each(lambda plant: plant.internal_momentum_body(), lambda alive: np.full(3, np.nan),
                          lambda values: np.array(values, dtype=float))

    def apply(self, command: dict) -> dict:
        """Each world's row of `command` (key -> (N, ...)) to its plant; row -> the exception of
        the worlds whose plant refused it ({} when none did)."""
        failures = {}
        for row, (plant, given) in enumerate(zip(self.plants, rows_of(command, len(self.plants)))):
            try:
                plant.apply(given)
            except BaseException as exc:
                failures[row] = exc
        return failures

    def step(self) -> None:
        """One control tick of physics in every world (each world's own `Plant.stepper`)."""
        for advance in self.step_calls():
            advance()

    def step_calls(self) -> list:
        """The calls that step each world one control tick, one per world, independent of each
        other (a batch may run them on several threads: testbed.batch.physics_threads)."""
        return self.steppers

    def check_state(self, t0: float, nstep: int) -> dict:
        """row -> SimulationDiverged of each world whose physics met a bad state within the `nstep`
        steps since t0 [s] (`Plant.check_state`)."""
        failures = {}
        for row, plant in enumerate(self.plants):
            try:
                plant.check_state(t0, nstep)
            except SimulationDiverged as exc:
                failures[row] = exc
        return failures


def group_of(plants: list, steps: int):
    """The plants' group: their class's `Plant.group_form` when all are of one class that has one,
    else `PerWorldPlants`."""
    kinds = {type(plant) for plant in plants}
    form = kinds.pop().group_form if len(kinds) == 1 else None
    return (form or PerWorldPlants)(plants, steps)
