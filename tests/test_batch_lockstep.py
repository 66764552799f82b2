"""Many worlds in lockstep (testbed.batch) against the same cases run one by one.

A world of a batch is its own run: each world's status, checks and metrics must be those of its
single run. Where every slot runs per world the arithmetic is the single run's, so they agree to
the bit; a slot with a batched form agrees to its round-off (BATCHED_REL, from the conditioning of
the metrics compared: end errors and drifts of well-conditioned runs, a few ulps of the state
amplified by at most the runs' length).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import testbed
from testbed.batch import Batch, run_batch
from testbed.campaign.orchestration import load_cases
from testbed.run_core.plan import prepare
from testbed.scenario.loading import parse

# metrics of a batched world against its single run: relative to the metric's own size or to
# ABS_FLOOR where it sits at the round-off floor (a drift of 1e-15 may come out 3e-15)
BATCHED_REL, ABS_FLOOR = 1e-9, 1e-13
# A drift (momentum, energy: |X(t) - X(0)| / scale) is a difference of nearly equal numbers, at the
# round-off floor of the run: an ulp moved early in a closed loop moves it by ~1e-13 (measured
# 1.2e-13 on a 175 s flagship). Its band is 1 % of the tightest drift check shipped (1e-9).
DRIFT_ABS = 1e-11
# The servo's miss (gimbal_rate_error_rel: |rate - command| / command) is ~1e-3 of the command it is
# taken from, so it carries 1e3 times the command's relative round-off: with one ulp of a torque
# summed in another order at t = 150 s (measured before the batched steering summed it as the single
# law does), the commands of a 175 s flagship agreed to 3e-10 and the miss to 4e-8. Its band, 1e-6
# of the miss, is 1e-9 of the command: room for another CPU's vectorised sin and cos.
MISS_REL = 1e-6


def agree(single, batched) -> None:
    """A batched world's result is its single run's: status, error, checks' verdicts, metrics."""
    assert batched.status == single.status, (single.scenario, batched.error, single.error)
    assert batched.error == single.error
    assert [(c["name"], c["passed"]) for c in batched.checks] == [(c["name"], c["passed"]) for c in single.checks]
    assert batched.metrics.keys() == single.metrics.keys()
    for name, value in single.metrics.items():
        other = batched.metrics[name]
        if isinstance(value, float) and math.isnan(value):
            assert isinstance(other, float) and math.isnan(other), name
        else:
            floor = DRIFT_ABS if "drift" in name else ABS_FLOOR
            rel = MISS_REL if name == "gimbal_rate_error_rel" else BATCHED_REL
            assert other == pytest.approx(value, rel=rel, abs=floor), name


def singles_and_batch(scenarios):
    singles = [testbed.run(scenario) for scenario in scenarios]
    return singles, run_batch([prepare(scenario) for scenario in scenarios])


def test_the_flagship_in_lockstep_is_each_world_run_alone():
    rates = ([0.25, -0.25, 0.0], [0.4, -0.1, 0.2], [-0.3, 0.35, -0.1])  # two of them not in the repository
    scenarios = [testbed.load("lebedev_spinup_cmg", ["sim.duration_s=40", f"initial.omega_deg_s={list(w)}"])
                 for w in rates]
    singles, batched = singles_and_batch(scenarios)
    for single, world in zip(singles, batched):
        agree(single, world)
    # the worlds differ: a batch that handed one world's numbers to another would not pass above
    assert len({r.metrics["spin_error_final_deg_s"] for r in batched}) == 3


def campaign_scenarios(name: str, indices, overrides=()):
    _, _, cases = load_cases(name, list(overrides), indices)
    return [parse(case.data, case.source) for case in cases]


def test_a_slew_campaign_in_lockstep_is_each_case_run_alone():
    scenarios = campaign_scenarios("reorient_campaign", [0, 1, 2, 3], ["sim.duration_s=20"])
    singles, batched = singles_and_batch(scenarios)
    for single, world in zip(singles, batched):
        agree(single, world)


def test_a_fault_campaign_in_lockstep_is_each_case_run_alone():
    scenarios = campaign_scenarios("reorient_fault_campaign", [0, 1, 2], ["sim.duration_s=60"])
    singles, batched = singles_and_batch(scenarios)
    for single, world in zip(singles, batched):
        agree(single, world)


class FailingGyro:
    """A sensor that fails at t >= `after` [s] in the one world it is given to."""

    def __init__(self, after: float):
        self.after = after

    def measure(self, t, plant):
        if t >= self.after:
            raise RuntimeError("the gyro's bus went quiet")
        return {"y": np.array([float(np.sum(plant.omega())) / math.sqrt(3.0)])}


def test_a_world_that_fails_leaves_the_batch_and_the_others_go_on():
    overrides = ["sim.duration_s=10"]  # the flagship's gyro axis is (1, 1, 1)/sqrt(3), as FailingGyro's
    scenarios = [testbed.load("lebedev_spinup_cmg", overrides + [f"initial.omega_deg_s=[{w}, 0.1, 0.0]"])
                 for w in (0.2, 0.3, 0.4)]
    stages = [{"sensor": FailingGyro(99.0)}, {"sensor": FailingGyro(2.5)}, {"sensor": FailingGyro(99.0)}]
    singles = [testbed.run(s, stages={"sensor": FailingGyro(g["sensor"].after)}) for s, g in zip(scenarios, stages)]
    plans = [prepare(s, g) for s, g in zip(scenarios, stages)]
    with Batch(plans) as batch:
        batch.advance(batch.timing.n_ticks)
        batched = batch.finish()
    assert [r.status for r in batched] == ["ok", "error", "ok"]
    assert "the gyro's bus went quiet" in batched[1].error and "t = 2.5 s" in batched[1].error
    for single, world in zip(singles, batched):
        agree(single, world)
    # the failed world's trace stops where its single run's does
    assert batched[1].sim_s == singles[1].sim_s < batched[0].sim_s


def test_worlds_of_different_timing_are_refused_together():
    plans = [prepare(testbed.load("lebedev_spinup_cmg", [f"sim.duration_s={d}"])) for d in (5, 6)]
    with pytest.raises(ValueError, match="share one timing"):
        Batch(plans)


def test_each_world_writes_its_own_trace(tmp_path):
    scenarios = [testbed.load("lebedev_spinup_cmg", ["sim.duration_s=8", f"initial.omega_deg_s=[{w}, -0.2, 0.1]"])
                 for w in (0.1, 0.3)]
    singles = [testbed.run(s, out=tmp_path / f"single{i}.rrd") for i, s in enumerate(scenarios)]
    outs = [tmp_path / f"world{i}.rrd" for i in range(2)]
    run_batch([prepare(s) for s in scenarios], outs)
    for single, out in zip(singles, outs):
        back, alone = testbed.read(out), testbed.read(single.rrd)
        agree(alone, back)
        for key in ("truth/omega", "law/torque", "allocator/gimbal_rates"):
            assert np.array_equal(back.trace[key][1], alone.trace[key][1]), key


def test_a_batch_stopped_by_an_exception_leaves_no_trace_behind(tmp_path):
    scenarios = [testbed.load("lebedev_spinup_cmg", ["sim.duration_s=8"]) for _ in range(2)]
    outs = [tmp_path / f"world{i}.rrd" for i in range(2)]
    with pytest.raises(KeyboardInterrupt):
        with Batch([prepare(s) for s in scenarios], outs) as batch:
            batch.advance(10)
            raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


def test_physics_on_two_threads_changes_no_world_by_a_bit():
    # each world's MjData is its own: the threads only change which core steps it
    rates = ([0.25, -0.25, 0.0], [0.4, -0.1, 0.2], [-0.3, 0.35, -0.1], [0.1, 0.1, 0.1], [0.0, -0.2, 0.3])
    scenarios = [testbed.load("lebedev_spinup_cmg", ["sim.duration_s=20", f"initial.omega_deg_s={list(w)}"])
                 for w in rates]
    alone = run_batch([prepare(s) for s in scenarios], keep_data=True)
    threaded = run_batch([prepare(s) for s in scenarios], keep_data=True, threads=2)
    for one, two in zip(alone, threaded):
        assert one.metrics == two.metrics
        assert np.array_equal(one.trace["truth/omega"][1], two.trace["truth/omega"][1])


def test_a_batch_closed_before_its_end_is_each_run_closed_there():
    scenarios = [testbed.load("lebedev_spinup_cmg", ["sim.duration_s=20", f"initial.omega_deg_s=[{w}, -0.2, 0.1]"])
                 for w in (0.1, 0.2, 0.3, 0.4)]
    with Batch([prepare(s) for s in scenarios]) as batch:
        batch.advance(123)
        batched = batch.finish()
    for scenario, world in zip(scenarios, batched):
        sim = testbed.Simulation(scenario)
        for _ in range(123):
            sim.step()
        agree(sim.close(), world)
        assert world.sim_s == pytest.approx(123 * 0.05)
