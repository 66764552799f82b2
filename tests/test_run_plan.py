"""The run's plan (testbed.run_core.plan): a validated scenario carries only its declared fields,
the plan's timing multiplies back to the periods it was read from, a run ends at the plan's end
time, the stage contract's defaults are the Protocols', and one conservation rule decides."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from testbed.run_core.conservation import Conservation
from testbed.run_core.plan import prepare
from testbed.run_core.stage_contract import Allocator, Declared, Law
from testbed.run_core.timing import Timing
from testbed.scenario.loading import SimConfig, load_scenario
from testbed.scenario.shipped_files import SCENARIO_DIR

SHIPPED = sorted(p.stem for p in SCENARIO_DIR.glob("*.yaml"))
# dt, control, estimator, trace [s]: not a shipped combination; ratios 5, 5, 2
ODD_PERIODS = ["sim.dt_s=0.004", "sim.control_period_s=0.1", "sim.estimator_period_s=0.02",
               "sim.trace_period_s=0.04", "sim.duration_s=1.3"]


@pytest.fixture(scope="module")
def shipped():
    return {name: load_scenario(name) for name in SHIPPED}


def test_a_validated_sim_block_holds_only_its_declared_fields(shipped):
    """SimConfig.validate fills its defaults and attaches nothing else (the counts are the plan's)."""
    declared = {f.name for f in dataclasses.fields(SimConfig)}
    for name, scenario in shipped.items():
        assert set(vars(scenario.sim)) == declared, name


@pytest.mark.parametrize("overrides", [[], ODD_PERIODS], ids=["shipped", "odd_periods"])
def test_the_timing_multiplies_back_to_its_periods(shipped, overrides):
    """Each whole count times its unit gives the period it was read from (exact ratios: the
    products agree to round-off, 1e-12 relative), and the end time is the whole number of ticks."""
    scenarios = shipped.values() if not overrides else [load_scenario("torque_free_tumble", overrides)]
    for scenario in scenarios:
        sim, timing = scenario.sim, Timing.of(scenario.sim)
        loop_period = timing.sample_period_s if timing.multirate else timing.control_period_s
        for product, period in ((timing.steps_per_tick * sim.dt_s, sim.control_period_s),
                                (timing.steps_per_sample * sim.dt_s, sim.estimator_period_s),
                                (timing.samples_per_tick * sim.estimator_period_s, sim.control_period_s),
                                (timing.trace_every * loop_period, sim.trace_period_s),
                                (timing.n_ticks * sim.control_period_s, sim.duration_s),
                                (timing.end_time_s, sim.duration_s)):
            assert product == pytest.approx(period, rel=1e-12), scenario.name
        assert timing.envelope_rows == (1 if sim.trace_envelope_s is None
                                        else round(sim.trace_envelope_s / sim.trace_period_s))
    if overrides:
        assert (timing.steps_per_tick, timing.steps_per_sample, timing.samples_per_tick, timing.trace_every,
                timing.n_ticks) == (25, 5, 5, 2, 13)


def test_a_multirate_run_ends_at_the_plans_end_time():
    """The last trace sample is the final state at the plan's end time, bit for bit (the loop and
    the plan form the same product), and every sensor sample of a trace period was recorded."""
    import testbed

    scenario = load_scenario("torque_free_tumble", ODD_PERIODS)
    plan = prepare(scenario)
    result = testbed.run(scenario)
    t, _ = result.trace["truth/omega"]
    assert t[-1] == plan.timing.end_time_s == result.sim_s
    assert math.isclose(t[-1], 1.3, rel_tol=1e-12)
    # a trace sample every 2 sensor samples (0.04 s) over 1.3 s: 33 on the grid, the last of them
    # at 1.28 s, then the final state at 1.3 s
    assert len(t) == 34 and np.allclose(np.diff(t[:-1]), 0.04, rtol=1e-9)


def test_a_stage_that_declares_nothing_gets_the_protocols_defaults():
    """Declared's defaults are those the slots' Protocols state; what a stage declares is read."""
    nothing = Declared.of(object())
    assert nothing == Declared()
    assert (nothing.output, nothing.needs_actuators, nothing.inputs) == (Allocator.output, Allocator.needs_actuators,
                                                                          Law.inputs)

    class OpenLoop:
        output, needs_actuators, statistics = "body_torque", False, {"calls": 3}

    declared = Declared.of(OpenLoop())
    assert (declared.output, declared.needs_actuators, declared.statistics) == ("body_torque", False, {"calls": 3})
    assert declared.inputs == () and declared.design is None


@pytest.mark.parametrize("name, momentum, energy", [
    ("torque_free_tumble", True, True),         # a free body, nothing commanded
    ("cmg_open_loop", True, False),             # internal actuators only: they work on the bus
    ("lebedev_detumble_ideal", False, False),   # an ideal body torque from outside
    ("orbit_libration", False, False),          # the gravity gradient's torque
])
def test_one_conservation_rule(name, momentum, energy):
    """What the scenario can conserve (Conservation.of) is what the drift metrics exist for and
    what the plant records its energy for; after the run the plant says whether its physics kept
    it (a body torque applied breaks both)."""
    from testbed.metrics import available

    scenario = load_scenario(name, ["sim.duration_s=" + repr(10 * load_scenario(name).sim.control_period_s)])
    rule = Conservation.of(scenario)
    assert (rule.momentum, rule.energy) == (momentum, energy)
    metrics = available(scenario)
    assert ("momentum_drift_rel" in metrics, "energy_drift_rel" in metrics) == (momentum, energy)
    plan = prepare(scenario)
    assert plan.conservation == rule and plan.plant.record_energy == energy
    assert rule.kept_by(plan.plant) == rule  # nothing has acted yet
    plan.plant.apply({"body_torque": np.array([0.0, 0.0, 1e-3])})
    assert plan.plant.external_wrench() and rule.kept_by(plan.plant) == Conservation(False, False)
