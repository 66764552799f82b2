"""The attitude stages' batched forms (testbed.batch.stacked_stages) against the same worlds run
one by one: quaternion and MRP feedback, the slew law (its program and tracking law on (N, ...)
rows), ideal attitude sensing with each world's own noise, and the pass-through estimator and
torque allocator.

Every world here is not in the repository (other axes, angles, inertias, noise seeds, start
times). Tolerance: `agree`'s BATCHED_REL = 1e-9 of each metric (ABS_FLOOR at the round-off
floor). The forms run each world's own arithmetic in the same order (no matmul kernel that
differs between one matrix and a stack: testbed.math.matvec), so the rows come out equal to
the bit as measured; the tolerance is the contract's, from the metrics' conditioning (end
errors of 1e-6 rad amplified through a few hundred closed-loop ticks).
"""

from __future__ import annotations

import numpy as np
import pytest

import testbed
from test_batch_lockstep import agree
from testbed.batch import Batch
from testbed.batch.stage_forms import PerWorld, WorldsFailed
from testbed.run_core.plan import prepare
from testbed.scenario.loading import parse

RIGID = {"name": "mrp_worlds", "model": {"system": "satellite", "inertia_kg_m2": [800, 1000, 1200], "mass_kg": 500},
         "initial": {"quat": [1, 0, 0, 0]}, "sim": {"duration_s": 30, "dt_s": 0.01, "control_period_s": 0.05},
         "pipeline": {"sensor": {"type": "ideal_attitude"}, "estimator": {"type": "attitude"},
                      "allocator": {"type": "ideal_torque"}}}
AXES = ([1.0, 0.0, 0.0], [0.0, 0.6, 0.8], [0.48, -0.6, 0.64], [-0.36, 0.48, 0.8])


def batched_and_singles(scenarios):
    """(each world's single result, the batch's results, the batch's forms by slot)."""
    singles = [testbed.run(scenario) for scenario in scenarios]
    with Batch([prepare(scenario) for scenario in scenarios]) as batch:
        forms = dict(batch.forms)
        batch.advance(batch.timing.n_ticks)
        return singles, batch.finish(), forms


def mrp_world(i: int, axis):
    law = {"type": "mrp_feedback", "gain_k_nm": 60.0 + 10 * i, "gain_p_nms": 150.0 + 20 * i, "axis": axis,
           "angle_deg": 20.0 + 25 * i, "start_s": 0.5 * i}
    sensor = {"type": "ideal_attitude", "attitude_noise_rad": 1e-5 * (i % 2), "rate_noise_rad_s": 2e-6,
              "seed": 100 + i}
    model = RIGID["model"] | {"inertia_kg_m2": [700 + 60 * i, 1000, 1300 - 40 * i]}
    return parse(RIGID | {"model": model, "pipeline": RIGID["pipeline"] | {"law": law, "sensor": sensor}}, "mrp_worlds")


def test_mrp_worlds_with_their_own_noise_are_each_world_run_alone():
    singles, batched, forms = batched_and_singles([mrp_world(i, axis) for i, axis in enumerate(AXES)])
    assert not any(isinstance(form, PerWorld) for form in forms.values())  # every slot batched
    for single, world in zip(singles, batched):
        agree(single, world)
    # the worlds differ (another world's numbers or noise would not pass above)
    assert len({world.metrics["final_pointing_error_deg"] for world in batched}) == len(AXES)


def test_quaternion_feedback_worlds_are_each_world_run_alone():
    scenarios = [testbed.load("slew_quaternion_feedback_ideal", [
        "sim.duration_s=25", f"pipeline.law.axis={axis}", f"pipeline.law.angle_deg={-50 + 35 * i}",
        f"pipeline.law.rate_limit_deg_s={1.0 + 0.5 * i}", f"model.inertia_kg_m2=[{650 + 80 * i}, 1000, 1200]"])
        for i, axis in enumerate(AXES)]
    singles, batched, forms = batched_and_singles(scenarios)
    assert {slot: type(forms[slot]).__name__ for slot in ("sensor", "estimator", "law")} == {
        "sensor": "IdealAttitudeWorlds", "estimator": "StatelessForm", "law": "StatelessForm"}
    for single, world in zip(singles, batched):
        agree(single, world)


@pytest.mark.slow
def test_slew_worlds_with_other_programs_are_each_world_run_alone():
    # cubic and versine programs side by side, other start times, axes, angles and inertias
    scenarios = [testbed.load("reorient_minimax", [
        "sim.duration_s=15", f"pipeline.law.axis={axis}", f"pipeline.law.angle_deg={35 + 20 * i}",
        f"pipeline.law.duration_s={12 + 2 * i}", f"pipeline.law.start_s={1 + i}",
        f"pipeline.law.profile={'versine' if i % 2 else 'cubic'}",
        f"model.inertia_kg_m2=[{700 + 50 * i}, 1000, {1250 - 30 * i}]"]) for i, axis in enumerate(AXES)]
    singles, batched, forms = batched_and_singles(scenarios)
    assert type(forms["law"]).__name__ == "StatelessForm"
    for single, world in zip(singles, batched):
        agree(single, world)


def law_form_and_stages(scenarios):
    stages = [prepare(scenario).pipeline.law for scenario in scenarios]
    return type(stages[0]).batched(stages), stages


@pytest.mark.parametrize("name", ["slew_quaternion_feedback_ideal", "reorient_minimax"])
def test_a_bad_estimate_fails_its_world_alone_as_its_single_run_would(name):
    scenarios = [testbed.load(name, [f"pipeline.law.axis={axis}"]) for axis in AXES[:3]]
    form, stages = law_form_and_stages(scenarios)
    rng = np.random.default_rng(5)
    quat = rng.normal(size=(3, 4))
    quat /= np.linalg.norm(quat, axis=1, keepdims=True)
    estimate = {"quat": quat, "omega": rng.normal(scale=0.01, size=(3, 3)), "internal_momentum": np.zeros((3, 3))}
    estimate["quat"][1] = [1e200, 1e200, 0.0, 0.0]  # overflows the law's products (or its unit check)
    with np.errstate(over="raise", invalid="raise", divide="raise"), pytest.raises(WorldsFailed) as caught:
        form.torque(12.0, estimate)
    assert list(caught.value.failures) == [1]
    # the world's own stage, as its single run's tick reports it
    pipeline = prepare(scenarios[1]).pipeline
    given = {key: value[1] for key, value in estimate.items()}
    with np.errstate(over="raise", invalid="raise", divide="raise"), pytest.raises(Exception) as alone:
        stages[1].torque(12.0, given)
    with pytest.raises(Exception) as expected:
        pipeline._raise_failure(12.0, "law", alone.value)
    assert str(caught.value.failures[1]) == str(expected.value)
    # its batch-mates' rows are their own stages' outputs
    for row in (0, 2):
        own = stages[row].torque(12.0, {key: value[row] for key, value in estimate.items()})
        for key, value in own.items():
            np.testing.assert_array_equal(caught.value.outputs[key][row], value)


def mekf_world(i: int, axis, extra=()):
    return testbed.load("slew_quaternion_feedback_mekf", [
        "sim.duration_s=20", f"pipeline.law.axis={axis}", f"pipeline.law.angle_deg={30 + 20 * i}",
        f"pipeline.sensor.star_tracker.seed={300 + i}", f"pipeline.sensor.gyro.seed={400 + i}",
        f"pipeline.sensor.gyro.initial_bias_rad_s=[{-1e-4 * i}, 5e-5, {3e-5 * i}]",
        f"pipeline.estimator.first_fix={'tracker' if i == 3 else 'scenario'}", *extra])


def test_mekf_worlds_with_their_own_sensors_are_each_world_run_alone():
    # other noise seeds, biases, slews; one world starts from the tracker's first fix, one has an outage
    scenarios = [mekf_world(i, axis, ["pipeline.sensor.star_tracker.outages_s=[[4, 7.5]]"] if i == 1 else [])
                 for i, axis in enumerate(AXES)]
    singles, batched, forms = batched_and_singles(scenarios)
    assert {slot: type(forms[slot]).__name__ for slot in ("sensor", "estimator")} == {
        "sensor": "StarTrackerGyroWorlds", "estimator": "MekfWorlds"}
    for single, world in zip(singles, batched):
        agree(single, world)
    assert len({world.metrics["final_pointing_error_deg"] for world in batched}) == len(AXES)


def test_a_filter_that_coasts_past_its_bound_fails_its_world_alone():
    # an angle random walk of 1e-3 rad/s^0.5 with the tracker out from 4 s: the attitude 3-sigma
    # passes the filter's first-order bound sqrt(2 sigma_tracker) = 0.40 deg after about 5 s of coasting
    noisy = ["pipeline.sensor.gyro.angle_random_walk_rad_sqrt_s=1e-3",
             "pipeline.sensor.star_tracker.outages_s=[[4, 100]]"]
    scenarios = [mekf_world(0, AXES[0]), mekf_world(1, AXES[1], noisy), mekf_world(2, AXES[2])]
    singles, batched, _ = batched_and_singles(scenarios)
    assert [world.status for world in batched] == ["ok", "method_failed", "ok"]
    assert "no star tracker fix" in batched[1].error
    for single, world in zip(singles, batched):
        agree(single, world)


def test_a_filter_whose_numbers_overflow_fails_its_world_alone():
    # a hostile world: a gyro reading of 1e300 rad/s overflows its filter's propagation (the
    # covariance's products), which ends its single run; its batch-mates' filters go on
    scenarios = [mekf_world(i, AXES[i]) for i in range(3)]
    form = type(prepare(scenarios[0]).pipeline.estimator).batched(
        [prepare(scenario).pipeline.estimator for scenario in scenarios])
    alone = [prepare(scenario).pipeline.estimator for scenario in scenarios]
    rng = np.random.default_rng(3)
    measurement = {"gyro_stamp": np.full((3, 1), 0.1), "gyro_rate": rng.normal(scale=1e-3, size=(3, 3)),
                   "tracker_new": np.zeros((3, 1)), "tracker_stamp": np.full((3, 1), -1.0),
                   "tracker_quat": np.tile([1.0, 0.0, 0.0, 0.0], (3, 1))}
    measurement["gyro_rate"][1] = [1e300, 0.0, 0.0]
    with np.errstate(over="raise", invalid="raise", divide="raise"), pytest.raises(WorldsFailed) as caught:
        form.estimate(0.1, measurement, {})
    assert list(caught.value.failures) == [1]
    with np.errstate(over="raise", invalid="raise", divide="raise"), pytest.raises(FloatingPointError) as own:
        alone[1].estimate(0.1, {key: value[1] for key, value in measurement.items()}, {})
    assert str(own.value) in str(caught.value.failures[1])
    for row in (0, 2):
        expected = alone[row].estimate(0.1, {key: value[row] for key, value in measurement.items()}, {})
        for key, value in expected.items():
            np.testing.assert_array_equal(caught.value.outputs[key][row], value)


def test_mekf_worlds_with_slower_instruments_and_late_trackers():
    # a tracker every 3 ticks and a gyro every 2: batched; a tracker 0.2 s late: each world its own
    slower = ["pipeline.sensor.star_tracker.sample_period_s=0.3", "pipeline.sensor.gyro.sample_period_s=0.2"]
    for extra, forms_wanted in ((slower, ("StarTrackerGyroWorlds", "MekfWorlds")),
                                (["pipeline.sensor.star_tracker.latency_s=0.2"], ("PerWorld", "PerWorld"))):
        scenarios = [mekf_world(i, AXES[i], extra + ["sim.duration_s=12"]) for i in range(3)]
        singles, batched, forms = batched_and_singles(scenarios)
        assert (type(forms["sensor"]).__name__, type(forms["estimator"]).__name__) == forms_wanted
        for single, world in zip(singles, batched):
            agree(single, world)
