"""The steering allocators' batched form (testbed.steering.batched_stage) against each world's own stage.

Row by row, tick by tick: N worlds not in the repository (other gimbal angles, near-singular ones
among them, other demands) through the form and through their own single stages, fed the same
read-outs. The form's arithmetic is the single laws' on rows; what differs is round-off (numpy's
sines and cosines and sums for the stage's float loops, stacked solves). A difference of a few
ulps in J reaches the gimbal rates multiplied by J's condition number kappa = s_max / s_min, so
the band on the rates is RATE_ULPS ulps of kappa times their size: near a singular set the rates
are ill-conditioned and the band widens with kappa, as it must. Where the laws cut small singular
values (rcond = 1e-2) kappa is at most 1 / rcond in what they solve, and the band uses that.
Whole runs through `run_batch` must then agree with single runs metric by metric (`agree`).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

import testbed
from testbed.batch import run_batch
from testbed.batch.stage_forms import PerWorld, WorldsFailed, forms_of
from testbed.run_core.plan import prepare
from testbed.run_core.stage_contract import StageFailed
from testbed.steering.batched_stage import ROW_LAWS, BatchedSteering

sys.path.insert(0, str(Path(__file__).parent))
from test_batch_lockstep import agree  # noqa: E402

EPS = np.finfo(float).eps
RATE_ULPS = 64  # a few ulps of J, of the sums and of the solve, times kappa
# other gimbal angles [deg]: generic, near the rank-1 set beta = 0, near the rank-2 set b1 = b3, b2 = b4,
# the zero-momentum set, and one near the rhombus's 4h saturation
ANGLES = ([30.0, -60.0, -20.0, 50.0], [0.2, -0.1, 0.3, 0.05], [20.0, 70.0, 20.001, 70.0],
          [45.0, -45.0, -45.0, 45.0], [88.0, 91.0, -92.0, -89.0])
TICKS = 300


def scenario(angles, law: str, duration: float = 20.0, extra=()):
    return testbed.load("reorient_minimax", [f"sim.duration_s={duration}", f"model.gimbal_angles_deg={list(angles)}",
                                             f"pipeline.allocator.type={law}", *extra])


def limits(i: int, angles) -> list[str]:
    """World i's gimbal limits: none for world 0; else an acceleration limit (100 + 50 i deg/s^2, so
    u = a Tc binds at 10 deg/s) and travel stops a few degrees from gimbals 1 and 3's start."""
    if i == 0:
        return []
    stops = [[angles[0] - 2.0 * i, angles[0] + 3.0], None, [angles[2] - 4.0, angles[2] + 1.5 * i], None]
    return [f"pipeline.allocator.gimbal_acceleration_max_deg_s2={100 + 50 * i}",
            "pipeline.allocator.gimbal_angle_limits_deg=" + str(stops).replace("None", "null")]


def allocators(law: str, limited: bool = False):
    """Two sets of each world's allocator stage: one for the form, one to run alone."""
    scenarios = [scenario(angles, law, extra=limits(i, angles) if limited else ()) for i, angles in enumerate(ANGLES)]
    batched = [prepare(s).pipeline for s in scenarios]
    single = [prepare(s).pipeline.stages()["allocator"] for s in scenarios]
    return forms_of(batched)["allocator"], [p.stages()["allocator"] for p in batched], single


def demands(k: int, count: int, rng) -> tuple[np.ndarray, np.ndarray]:
    """Wanted torques [N m] and body rates [rad/s] at tick k: slow sines of different sizes per
    world (up to about twice what the 10 deg/s limit gives at h = 25 N m s), plus noise."""
    phase = 0.05 * k + np.arange(count)[:, None] * np.array([0.0, 2.1, 4.2])
    size = np.linspace(0.5, 8.0, count)[:, None]
    torque = size * np.sin(phase) + 0.1 * rng.standard_normal((count, 3))
    omega = 0.01 * np.cos(phase) + 1e-3 * rng.standard_normal((count, 3))
    return torque, omega


def condition(jacobian: np.ndarray, rcond: float) -> float:
    """kappa of what the law solves: s_max / s_min, s_min not below rcond s_max (the laws' cut)."""
    s = np.linalg.svd(jacobian, compute_uv=False)
    return float(s[0] / max(s[-1], rcond * s[0]))


@pytest.mark.parametrize("law, limited", [(law, False) for law in sorted(ROW_LAWS)] + [("minimax", True),
                                                                                       ("sr", True)])
def test_each_row_is_its_world_own_stage_tick_by_tick(law, limited):
    """limited: the worlds but the first have gimbal limits of their own (the bounds, the set-points
    and the limits' counts per world)."""
    form, form_stages, stages = allocators(law, limited)
    assert isinstance(form, BatchedSteering)
    count, rng = len(stages), np.random.default_rng(41)
    beta = np.radians(np.array(ANGLES))
    rotor = np.array([s.geometry.nominal_rotor_speed for s in stages])[:, None] * np.ones((1, 4))
    rate = np.zeros((count, 4))
    rcond = form.options.get("rcond", 1e-9)
    widest = 0.0
    for k in range(TICKS):
        t = 0.05 * k
        torque, omega = demands(k, count, rng)
        read = {"gimbal_angle": beta, "rotor_rate": rotor * (1 + 1e-4 * rng.standard_normal((count, 4))),
                "gimbal_rate": rate}
        rows = form.allocate(t, {"torque": torque}, {"omega": omega}, read)
        for i, stage in enumerate(stages):
            alone = stage.allocate(t, {"torque": torque[i]}, {"omega": omega[i]},
                                   {key: value[i] for key, value in read.items()})
            kappa = condition(stage.geometry.unit_jacobian(beta[i]), rcond)
            widest = max(widest, condition(stage.geometry.unit_jacobian(beta[i]), 0.0))
            size = max(float(np.max(np.abs(alone["gimbal_rates"]))), stage.rate_max)
            band = RATE_ULPS * EPS * kappa * size
            assert rows["gimbal_rates"][i] == pytest.approx(alone["gimbal_rates"], abs=band), (k, i)
            assert rows["torque_delivered"][i] == pytest.approx(alone["torque_delivered"],
                                                                abs=band * 4 * stage.geometry.h), (k, i)
            # well conditioned: H(beta) and its read-outs to a few ulps of |H| <= 4 h
            held = 16 * EPS * 4 * stage.geometry.h
            assert rows["momentum"][i] == pytest.approx(alone["momentum"], abs=held)
            assert rows["held_momentum"][i] == pytest.approx(alone["held_momentum"], abs=held)
            assert rows["scale"][i] == pytest.approx(alone["scale"], abs=RATE_ULPS * EPS * kappa)
            assert rows["singularity"][i] == pytest.approx(alone["singularity"], rel=1e-12, abs=1e-15)
            for key in ("rank", "status", "singularity_type"):
                assert rows[key][i] == alone[key], (key, k, i)
            assert list(rows) == list(alone)
        # the gimbals move with the command, so the worlds pass near and through their singular sets
        rate = rows["gimbal_rates"]
        beta = beta + 0.05 * rate
    assert widest > 1e3, "no world came near a singular set: the band above was never tested"
    for row, (batched, alone) in enumerate(zip(form_stages, stages)):
        form.settle(row)
        assert batched.statistics.keys() == alone.statistics.keys()
        for name, value in alone.statistics.items():
            assert batched.statistics[name] == pytest.approx(value, rel=1e-9, abs=1e-13), name
        assert batched.statistics["steps"] == TICKS
        if limited and row:  # the limits bound the commands (counted as the single stage counts them)
            assert np.allclose(batched.setpoint, alone.setpoint, rtol=0, atol=1e-12)
            assert alone.statistics["acceleration_violations"] == alone.statistics["angle_limit_violations"] == 0
            assert alone.statistics["peak_gimbal_acceleration"] <= np.radians(100 + 50 * row) * (1 + 1e-9)


def test_a_world_with_a_bad_demand_fails_alone_as_its_stage_would():
    form, _, stages = allocators("minimax")
    count = len(stages)
    torque, omega = demands(3, count, np.random.default_rng(7))
    torque[2, 1] = np.nan
    read = {"gimbal_angle": np.radians(np.array(ANGLES)), "rotor_rate": np.full((count, 4), 628.3185307179587)}
    with pytest.raises(WorldsFailed) as failed:
        form.allocate(0.15, {"torque": torque}, {"omega": omega}, read)
    assert list(failed.value.failures) == [2]
    failure = failed.value.failures[2]
    assert isinstance(failure, StageFailed) and "steering.Hdot" in str(failure) and "minimax" in str(failure)
    with pytest.raises(Exception, match="steering.Hdot"):
        stages[2].allocate(0.15, {"torque": torque[2]}, {"omega": omega[2]}, {k: v[2] for k, v in read.items()})
    for i in (0, 1, 3, 4):  # the others' rows are their own stages' commands
        alone = stages[i].allocate(0.15, {"torque": torque[i]}, {"omega": omega[i]}, {k: v[i] for k, v in read.items()})
        assert np.all(np.isfinite(failed.value.outputs["gimbal_rates"][i]))
        assert failed.value.outputs["momentum"][i] == pytest.approx(alone["momentum"], abs=1e-12)


@pytest.mark.parametrize("law", ["minimax", "pinv"])
def test_whole_runs_in_a_batch_are_each_world_run_alone(law):
    # other slews and starts than the repository's reorient_minimax / reorient_pinv; worlds 1 and 3
    # with gimbal limits of their own (limits()), the others without
    cases = [([30.0, -60.0, -20.0, 50.0], [1, 0, 0], 40), ([45.0, -45.0, -45.0, 45.0], [0, 0.6, 0.8], 60),
             ([0.5, -0.5, 90.0, -90.0], [0.6, -0.8, 0], 30), ([10.0, 10.0, 10.0, 10.0], [0, 0, 1], 90)]
    scenarios = [scenario(angles, law, 25.0, [f"pipeline.law.axis={axis}", f"pipeline.law.angle_deg={angle}",
                                              "pipeline.law.duration_s=15", "pipeline.law.start_s=2",
                                              *limits(i % 2 * i, angles)])
                 for i, (angles, axis, angle) in enumerate(cases)]
    plans = [prepare(s) for s in scenarios]
    assert isinstance(forms_of([p.pipeline for p in plans])["allocator"], BatchedSteering)
    batched = run_batch(plans)
    singles = [testbed.run(s) for s in scenarios]
    for single, world in zip(singles, batched):
        agree(single, world)
    # the worlds differ: a batch that handed one world's numbers to another would not pass above
    assert len({r.metrics["max_tracking_error_deg"] for r in batched}) == len(cases)
    # world 1's limits bind: its commands reach its own acceleration limit and its gimbal a stop
    assert batched[1].metrics["peak_gimbal_acceleration_deg_s2"] == pytest.approx(150.0, rel=1e-9)
    assert abs(batched[1].metrics["min_gimbal_angle_margin_deg"]) < 0.01


@pytest.mark.parametrize("extra", [["pipeline.allocator.type=minimax_lp"],
                                   ["pipeline.allocator.fault_detection=true"],
                                   ["pipeline.allocator.options={null_motion_price: 0.0, rcond: 0.02}"]])
def test_which_worlds_run_per_world(extra):
    """An LP per world and fault isolation's state machine stay in the single stage: per world.
    Options that differ from world to world too (the form takes one set of options)."""
    plans = [prepare(scenario(ANGLES[0], "minimax", extra=extra)), prepare(scenario(ANGLES[1], "minimax"))]
    form = forms_of([p.pipeline for p in plans])["allocator"]
    assert isinstance(form, PerWorld)


def test_a_form_is_taken_for_every_law_on_rows_from_two_worlds():
    for law in ROW_LAWS:
        plans = [prepare(scenario(angles, law, 1.0)) for angles in ANGLES[:2]]
        assert isinstance(forms_of([p.pipeline for p in plans])["allocator"], BatchedSteering), law
        # one world alone keeps its own stage (rows of one cost more than its tick)
        assert isinstance(forms_of([plans[0].pipeline])["allocator"], PerWorld), law
    assert math.isclose(np.radians(10.0), plans[0].pipeline.stages()["allocator"].rate_max)
