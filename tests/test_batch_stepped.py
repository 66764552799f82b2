"""Issue 41: the stepped batch (testbed/batch/stepped.py) under the vector environments.

Independent numbers: each world run alone as a `testbed.Simulation` with the same plan inputs
and the same commands. Tolerance: none, bit for bit (every slot runs per world here, so a world
does the same arithmetic as its single run).
"""

from __future__ import annotations

import numpy as np
import pytest

import testbed
from testbed.batch.stepped import SteppedBatch
from testbed.run_core.plan import prepare
from testbed.scenario.loading import load_scenario as load

OVERRIDES = ["sim.duration_s=1", "initial.omega_deg_s=[0.5, -0.3, 0.2]"]


class RateDamping:
    """A law: torque = -gain omega_hat [N m]; it raises at t >= fail_at [s] (a stage's own fault)."""

    def __init__(self, gain: float, fail_at: float = np.inf):
        self.gain, self.fail_at = gain, fail_at

    def torque(self, t, estimate):
        if t >= self.fail_at:
            raise RuntimeError("the law's own fault")
        return {"torque": -self.gain * np.asarray(estimate["omega"])}


def laws():
    return [RateDamping(40.0), RateDamping(60.0, fail_at=0.3), RateDamping(80.0)]


def test_worlds_step_as_their_single_runs_and_a_failed_one_stops_alone():
    scenario = load("reorient_minimax", OVERRIDES)
    batch = SteppedBatch([prepare(scenario, {"law": law}, stepped=True) for law in laws()])
    singles = [testbed.Simulation("reorient_minimax", OVERRIDES, stages={"law": law}, keep_trace=False)
               for law in laws()]
    for _ in range(12):
        batch.step()
        for sim in singles:
            sim.step()
    assert batch.status == [sim.status for sim in singles] == ["ok", "error", "ok"]
    assert batch.error[1] == singles[1].error and "the law's own fault" in batch.error[1]
    assert batch.ticks.tolist() == [sim.ticks for sim in singles] == [12, 6, 12]
    for plant, sim in zip(batch.plants, singles):
        assert np.array_equal(plant.omega(), sim.plant.omega()) and np.array_equal(plant.quat(), sim.plant.quat())
    # world 1 restarts with a law that does not fail: a cohort of its own at t = 0, stepped alone
    batch.restart([1], [prepare(scenario, {"law": RateDamping(60.0)}, stepped=True)])
    assert len(batch.cohorts) == 2 and batch.status[1] == "ok" and batch.ticks[1] == 0
    fresh = testbed.Simulation("reorient_minimax", OVERRIDES, stages={"law": RateDamping(60.0)}, keep_trace=False)
    for _ in range(3):
        batch.step(rows=np.array([False, True, False]))
        fresh.step()
    assert batch.ticks.tolist() == [12, 3, 12]
    assert np.array_equal(batch.plants[1].omega(), fresh.plant.omega())
    with pytest.raises(ValueError, match="started together"):
        batch.step(rows=np.array([True, True, False]))
    for sim in (*singles, fresh):
        sim.close()


def test_a_given_output_takes_the_slot_of_every_world():
    scenario = load("reorient_minimax", OVERRIDES)
    torques = np.array([[0.5, 0.0, -0.2], [0.0, 1.0, 0.0]])
    batch = SteppedBatch([prepare(scenario, stepped=True) for _ in range(2)])
    singles = [testbed.Simulation("reorient_minimax", OVERRIDES, keep_trace=False) for _ in range(2)]
    for _ in range(5):
        batch.step({"law": {"torque": torques}})
        for sim, torque in zip(singles, torques):
            sim.step({"law": {"torque": torque}})
    for plant, sim in zip(batch.plants, singles):
        assert np.array_equal(plant.omega(), sim.plant.omega())
    assert not np.array_equal(batch.plants[0].omega(), batch.plants[1].omega())  # the commands differ
    for sim in singles:
        sim.close()
