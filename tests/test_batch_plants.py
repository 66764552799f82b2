"""The CMG plants of a batch on (N, ...) arrays (testbed/systems/cmg_cluster/plants_group.py)
against each world's own plant, and whole batches that use it against single runs.

The group computes the servo's arithmetic in the scalar servo's operation order, so its rows are
its worlds' to the bit wherever NumPy's sin and cos round as the math module's; ROW_REL allows
a few ulps of a trigonometric value carried through a few hundred ticks of the stable servo loop,
a million times below any physical difference (a servo miss is ~1e-5 of a command).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

import testbed
from testbed.batch import Batch
from testbed.batch.plant_group import PerWorldPlants
from testbed.run_core.plan import prepare
from testbed.systems.cmg_cluster.faults import FaultEvent
from testbed.systems.cmg_cluster.plant import CmgPlant
from testbed.systems.cmg_cluster.plants_group import GROUP_FROM_WORLDS, CmgPlantGroup
from testbed.systems.cmg_rhombus import CmgRhombusParams, build
from tests.test_batch_lockstep import FailingGyro, agree, campaign_scenarios

ROW_REL = 1e-12
DT, TC = 0.01, 0.05
STEPS = round(TC / DT)

# worlds no scenario has: other gimbal angles, momenta, servo frequencies and dampings, rate
# limits (one per world, one with none), a gimbal torque limit low enough to bind, and faults
FEEDFORWARD_WORLDS = [
    dict(gimbal_angles_deg=[20, -50, 10, 80], rotor_momentum_nms=37.0, servo_natural_frequency_rad_s=3.0,
         gimbal_rate_limit_deg_s=8.0),
    dict(gimbal_angles_deg=[-35, 60, 15, -5], rotor_momentum_nms=52.0, servo_natural_frequency_rad_s=11.0,
         servo_damping_ratio=0.7, gimbal_rate_limit_deg_s=4.0, gimbal_torque_limit_nm=0.4),
    dict(gimbal_angles_deg=[70, 10, -80, 30], rotor_momentum_nms=25.0, servo_natural_frequency_rad_s=0.4),
    dict(gimbal_angles_deg=[5, -5, 45, -45], rotor_momentum_nms=60.0, servo_natural_frequency_rad_s=6.0,
         gimbal_rate_limit_deg_s=12.0,
         faults=[FaultEvent(at_s=3.0, unit=2, kind="stuck"),
                 FaultEvent(at_s=5.0, unit=4, kind="rate_limit", rate_limit_deg_s=2.0),
                 FaultEvent(at_s=6.0, unit=1, kind="sensor_bias", bias_deg_s=0.5)]),
    dict(gimbal_angles_deg=[-60, -20, 25, 50], rotor_momentum_nms=44.0, servo_natural_frequency_rad_s=2.0,
         servo_damping_ratio=1.4, gimbal_rate_limit_deg_s=6.0,
         faults=[FaultEvent(at_s=4.0, unit=3, kind="spin_down", time_constant_s=2.0)]),
]
OMEGA0 = [(0.004, -0.002, 0.003), (-0.01, 0.005, 0.0), (0.0, 0.0, 0.02), (0.003, 0.003, -0.003),
          (0.006, -0.001, 0.002)]


def plant_of(world: dict, omega0) -> CmgPlant:
    params = CmgRhombusParams(**({"inertia_kg_m2": [700.0, 900.0, 1100.0], "servo_model": "feedforward"} | world))
    plant = CmgPlant(build(params, DT), params, TC)
    plant.initialise(SimpleNamespace(omega=np.asarray(omega0, float), quat=np.array([0.9, 0.1, -0.3, 0.2]) /
                                     np.linalg.norm([0.9, 0.1, -0.3, 0.2])))
    return plant


def commands(rng, count: int, ticks: int) -> np.ndarray:
    """(ticks, count, 4) gimbal-rate commands [rad/s]: held for a few ticks, then jumping (past the
    jump refinement's threshold and past the tighter rate limits), now and then a small change."""
    out = np.zeros((ticks, count, 4))
    level = np.zeros((count, 4))
    for k in range(ticks):
        jump = rng.random(count) < 0.15
        level[jump] = rng.uniform(-0.25, 0.25, (int(jump.sum()), 4))
        level = level + rng.normal(0.0, 2e-4, level.shape)
        out[k] = level
    return out


def assert_rows(group_values: dict, singles: list[dict]) -> None:
    assert list(group_values) == list(singles[0])  # the same keys, in the same order
    for key, value in group_values.items():
        expected = np.array([single[key] for single in singles])
        assert value.shape == expected.shape, key
        scale = max(1.0, float(np.max(np.abs(expected))))
        assert np.max(np.abs(value - expected)) <= ROW_REL * scale, key


def run_side_by_side(worlds: list[dict], ticks: int, seed: int) -> tuple[list, CmgPlantGroup, np.ndarray]:
    """The worlds stepped alone and in a group, tick by tick, with one random command sequence:
    actuator read-outs before the command, truth and ctrl after it (as a batch's tick reads them).
    Also each world's largest gimbal motor torque [N m] (feedforward)."""
    omegas = OMEGA0[:len(worlds)]
    alone = [plant_of(world, w) for world, w in zip(worlds, omegas)]
    group = CmgPlant.group_form([plant_of(world, w) for world, w in zip(worlds, omegas)], STEPS)
    assert isinstance(group, CmgPlantGroup)
    steppers = [plant.stepper(STEPS) for plant in alone]
    rng = np.random.default_rng(seed)
    peak = np.zeros(len(worlds))
    for k, command in enumerate(commands(rng, len(worlds), ticks)):
        assert_rows(group.actuator_state(), [plant.actuator_state() for plant in alone])
        for plant, row in zip(alone, command):
            plant.apply({"gimbal_rates": row})
        assert group.apply({"gimbal_rates": command}) == {}
        assert_rows(group.truth(), [plant.truth() for plant in alone])
        for plant, twin in zip(alone, group.plants):
            assert np.max(np.abs(twin.data.ctrl - plant.data.ctrl)) <= ROW_REL * max(1.0, np.max(np.abs(plant.data.ctrl)))
        for row, plant in enumerate(alone):
            peak[row] = max(peak[row], np.max(np.abs(plant.data.ctrl[plant.bus.gimbal_motor_ids]), initial=0.0))
        for advance in steppers:
            advance()
        group.step()
        if k % 10 == 9:
            assert group.check_state((k - 9) * TC, 10 * STEPS) == {}
    return alone, group, peak


def test_feedforward_rows_are_each_worlds_plant_tick_by_tick():
    alone, group, peak = run_side_by_side(FEEDFORWARD_WORLDS, 240, seed=5)
    # the sequence exercised what it is meant to: refined ticks, the torque limit, every fault
    refined = [plant.jumps.refined_calls for plant in alone]
    assert min(refined) > 10 and refined == [plant.jumps.refined_calls for plant in group.plants]
    limit = FEEDFORWARD_WORLDS[1]["gimbal_torque_limit_nm"]
    assert peak[1] == limit and np.all(np.delete(peak, 1) > limit)  # the limit bound, and only there
    assert set(alone[3].faults.codes.tolist()) == {0.0, 1.0, 3.0, 5.0} and alone[4].faults.codes[2] == 4.0
    # the stuck gimbal holds still (its servo's miss of 0), where its mates are commanded up to 0.25 rad/s
    assert abs(alone[3].truth()["gimbal_rate"][1]) < 1e-3
    # written back, each world's servo goes on as its twin alone
    for row in range(len(alone)):
        group.settle(row)
    for plant, twin in zip(alone, group.plants):
        assert np.array_equal(plant.servo.held_command(plant.data), twin.servo.held_command(twin.data))
        for name in ("_delta", "_predicted", "_torque", "_last_angle", "_last_rate", "_mean_before"):
            assert np.allclose(getattr(plant.servo, name), getattr(twin.servo, name), rtol=ROW_REL, atol=0.0), name


def test_intvelocity_rows_are_each_worlds_plant_tick_by_tick():
    worlds = [dict(world, servo_model="intvelocity", servo_natural_frequency_rad_s=frequency)
              for world, frequency in zip(FEEDFORWARD_WORLDS, (40.0, 60.0, 25.0, 50.0))]
    run_side_by_side(worlds, 150, seed=9)


def test_worlds_of_other_servos_or_too_few_run_per_world():
    plants = [plant_of(world, w) for world, w in zip(FEEDFORWARD_WORLDS[:3], OMEGA0)]
    plants.append(plant_of(dict(FEEDFORWARD_WORLDS[3], servo_model="intvelocity"), OMEGA0[3]))
    assert type(CmgPlant.group_form(plants, STEPS)) is PerWorldPlants
    assert type(CmgPlant.group_form(plants[:GROUP_FROM_WORLDS - 1], STEPS)) is PerWorldPlants


def batch_against_singles(scenarios) -> None:
    singles = [testbed.run(scenario) for scenario in scenarios]
    with Batch([prepare(scenario) for scenario in scenarios]) as batch:
        assert isinstance(batch.group, CmgPlantGroup)
        batch.advance(batch.timing.n_ticks)
        batched = batch.finish()
    for single, world in zip(singles, batched):
        agree(single, world)
    return batched


@pytest.mark.slow
def test_a_flagship_like_batch_is_each_world_run_alone():
    """The flagship's spin-up with other rates, servo frequencies and rate limits in each world."""
    worlds = [([0.3, -0.2, 0.05], 0.1, 10.0), ([-0.2, 0.3, 0.0], 0.3, 8.0), ([0.1, 0.1, -0.2], 0.05, 12.0),
              ([0.35, -0.05, 0.1], 0.2, 10.0)]
    scenarios = [testbed.load("lebedev_spinup_cmg", ["sim.duration_s=30", f"initial.omega_deg_s={w}",
                                                     f"model.servo_natural_frequency_rad_s={wn}",
                                                     f"model.gimbal_rate_limit_deg_s={limit}"])
                 for w, wn, limit in worlds]
    batched = batch_against_singles(scenarios)
    assert len({r.metrics["spin_error_final_deg_s"] for r in batched}) == len(worlds)


@pytest.mark.slow
def test_a_reorient_minimax_like_batch_is_each_world_run_alone():
    """Slews of other angles and axes, a gimbal torque limit in one world."""
    worlds = [(45, "[1, 0, 0]", []), (70, "[0, 0.6, 0.8]", ["model.gimbal_torque_limit_nm=2.0"]),
              (30, "[0.5773502691896258, 0.5773502691896258, 0.5773502691896258]", []),
              (55, "[0.8, -0.6, 0]", ["model.servo_natural_frequency_rad_s=8"])]
    scenarios = [testbed.load("reorient_minimax", ["sim.duration_s=25", "pipeline.law.duration_s=15",
                                                   f"pipeline.law.angle_deg={angle}", f"pipeline.law.axis={axis}",
                                                   *more])
                 for angle, axis, more in worlds]
    batch_against_singles(scenarios)


def test_a_world_that_fails_leaves_the_group_and_the_others_go_on():
    """The group drops the failed world's rows (keep) and writes its servo back (settle): the
    world's truth where it stopped, and its mates' runs after it, are their single runs'."""
    overrides = ["sim.duration_s=8"]  # the flagship's gyro axis is (1, 1, 1)/sqrt(3), as FailingGyro's
    scenarios = [testbed.load("lebedev_spinup_cmg", overrides + [f"initial.omega_deg_s=[{w}, 0.1, 0.0]"])
                 for w in (0.2, 0.3, 0.4, 0.5, -0.2)]
    after = (99.0, 2.5, 99.0, 4.05, 99.0)  # two worlds fail, one mid-block
    singles = [testbed.run(s, stages={"sensor": FailingGyro(a)}) for s, a in zip(scenarios, after)]
    with Batch([prepare(s, {"sensor": FailingGyro(a)}) for s, a in zip(scenarios, after)]) as batch:
        assert isinstance(batch.group, CmgPlantGroup)
        batch.advance(batch.timing.n_ticks)
        batched = batch.finish()
    assert [r.status for r in batched] == ["ok", "error", "ok", "error", "ok"]
    for single, world in zip(singles, batched):
        agree(single, world)
    assert batched[1].sim_s == singles[1].sim_s < batched[3].sim_s == singles[3].sim_s < batched[0].sim_s


@pytest.mark.slow
def test_a_fault_campaign_batch_is_each_case_run_alone():
    """Cases of the fault campaign through the group (a sensor bias, a motor off, a sensor dropout
    and a spin-down, drawn on other units at other times): each as its case alone runs it."""
    scenarios = campaign_scenarios("reorient_fault_campaign", [4, 5, 6, 7], ["sim.duration_s=45"])
    batched = batch_against_singles(scenarios)
    assert len({r.metrics["final_attitude_error_deg"] for r in batched}) == 4
