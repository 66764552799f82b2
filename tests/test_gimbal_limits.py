"""Gimbal-angle travel limits and the gimbal-acceleration limit (testbed/steering/gimbal_limits.py):
the braking curve against a brute-force braking sequence, the bounds over long random command
histories, every law inside the bounds, refusals before the run, and 0 violations on every shipped
scenario that steers (with limits imposed on each)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from testbed.errors import InputError
from testbed.runner import run_scenario
from testbed.scenario.loading import load_scenario
from testbed.scenario.shipped_files import SCENARIO_DIR
from testbed.steering import STEERING_LAWS, steer
from testbed.steering.gimbal_limits import GimbalLimits, stopping_rate
from rhombus_reference import rhombus_column_derivative, rhombus_jacobian

LAWS = sorted(STEERING_LAWS)


def braking_distance(rate, step, period):
    """Distance covered holding `rate` one period, then slowing by `step` each period to rest."""
    distance = 0.0
    while rate > 0.0:
        distance += rate * period
        rate -= step
    return distance


def test_stopping_rate_is_the_largest_rate_that_can_still_stop():
    rng = np.random.default_rng(30)
    for _ in range(2000):
        period, step, distance = rng.uniform(0.01, 0.1), rng.uniform(1e-3, 0.2), rng.uniform(0.0, 3.0)
        r = stopping_rate(distance, step, period)
        assert braking_distance(r, step, period) <= distance * (1 + 1e-9) + 1e-12
        assert braking_distance(r * (1 + 1e-6) + 1e-9, step, period) > distance
    assert stopping_rate(0.3, math.inf, 0.05) == pytest.approx(0.3 / 0.05, rel=1e-15)
    assert stopping_rate(-0.1, 0.1, 0.05) == 0.0 and stopping_rate(math.inf, 0.1, 0.05) == math.inf


def test_random_command_histories_stay_inside_every_limit():
    """Any command inside the bounds, step after step: the set-point never leaves its range, the
    rate changes by at most a_max Tc, and the bounds are never empty."""
    rng = np.random.default_rng(31)
    for _ in range(40):
        period = 0.05
        low, high = -rng.uniform(0.1, 2.0, 4), rng.uniform(0.1, 2.0, 4)
        limits = GimbalLimits(low, high, rng.uniform(0.05, 5.0), period)
        rate_max = rng.uniform(0.05, 1.0)
        setpoint, previous = rng.uniform(low, high), np.zeros(4)
        for _ in range(600):
            lo, hi = limits.rate_bounds(setpoint, previous, rate_max)
            assert np.all(lo <= hi)
            command = np.clip(rng.normal(0.0, 2.0 * rate_max, 4), lo, hi)  # pushes at every bound
            assert np.all(np.abs(command - previous) <= limits.rate_step * (1 + 1e-12) + 1e-15)
            setpoint = setpoint + period * command
            assert np.all(setpoint >= low - 1e-12) and np.all(setpoint <= high + 1e-12)
            previous = command


@pytest.mark.parametrize("law", LAWS)
def test_every_law_stays_inside_per_gimbal_rate_bounds(law):
    rng = np.random.default_rng(32)
    alpha = 0.9
    for _ in range(100):
        beta = rng.uniform(-np.pi, np.pi, 4)
        h, hdot, rate_max = rng.uniform(1, 50), rng.normal(size=3) * 5.0, rng.uniform(0.1, 1.0)
        lo = rng.uniform(-rate_max, 0.5 * rate_max, 4)
        hi = lo + rng.uniform(0.0, rate_max, 4)  # boxes with and without zero inside
        options = {"column_derivative": rhombus_column_derivative(beta, alpha)} if law == "minimax_avoid" else {}
        J = rhombus_jacobian(beta, alpha)
        result = steer(law, J, h, hdot, rate_max, rate_bounds=(lo, hi), **options)
        assert np.all(result.beta_rate >= np.maximum(lo, -rate_max)) and np.all(result.beta_rate <= np.minimum(hi, rate_max))
        np.testing.assert_allclose(result.hdot_delivered, h * J @ result.beta_rate, rtol=1e-12, atol=1e-15 * h)
        if law in ("pinv", "minimax", "minimax_lp") and np.all(lo <= 0) and np.all(hi >= 0) and result.rank == 3:
            # zero inside the box: the demand is scaled, its direction kept
            np.testing.assert_allclose(result.hdot_delivered, result.scale * np.asarray(hdot),
                                       atol=1e-8 * np.linalg.norm(hdot))


@pytest.mark.parametrize("override, field, words", [
    ("pipeline.allocator.gimbal_angle_limits_deg=[[0, 90], null, null]", "pipeline.allocator.gimbal_angle_limits_deg",
     "cluster has 4"),
    ("pipeline.allocator.gimbal_angle_limits_deg=[[90, 0], null, null, null]",
     "pipeline.allocator.gimbal_angle_limits_deg[0]", "below max"),
    ("pipeline.allocator.gimbal_angle_limits_deg=[[0], null, null, null]",
     "pipeline.allocator.gimbal_angle_limits_deg[0]", "[min, max]"),
    ("pipeline.allocator.gimbal_angle_limits_deg=[null, [0, 90], null, null]",
     "pipeline.allocator.gimbal_angle_limits_deg[1]", "starts at -45"),
    ("pipeline.allocator.gimbal_acceleration_max_deg_s2=0", "pipeline.allocator.gimbal_acceleration_max_deg_s2", "> 0"),
    ("pipeline.allocator.options={rate_bounds: 1}", "pipeline.allocator.options.rate_bounds", "not an option"),
])
def test_impossible_limits_are_refused_before_the_run(override, field, words):
    from testbed.runner import prepare

    with pytest.raises(InputError) as err:
        prepare(load_scenario("reorient_minimax", [override]))
    assert err.value.field == field and words in err.value.reason


def steered_scenarios() -> list[str]:
    names = sorted(p.stem for p in SCENARIO_DIR.glob("*.yaml"))
    return [n for n in names if load_scenario(n).stages["allocator"][0] in STEERING_LAWS]


@pytest.mark.slow
@pytest.mark.parametrize("name", steered_scenarios())
def test_no_shipped_scenario_exceeds_imposed_gimbal_limits(name):
    """Each shipped steering scenario with 100 deg/s^2 and a +-60 deg travel about each starting
    angle imposed: the commands never pass a limit (whether the mission still succeeds is not the
    question here), and as shipped the counts are 0 too (tests/data/pinned_metrics.json)."""
    scenario = load_scenario(name)
    start = scenario.model.gimbal_angles_deg
    if start is None:  # a cmg_cluster array's own starting angles
        start = scenario.model.units().gimbal_angles_deg
    limits = "[" + ", ".join(f"[{a - 60:.9g}, {a + 60:.9g}]" for a in start) + "]"
    overrides = [f"pipeline.allocator.gimbal_angle_limits_deg={limits}",
                 "pipeline.allocator.gimbal_acceleration_max_deg_s2=100"]
    if name == "lebedev_spinup_cmg":
        overrides.append("sim.duration_s=250")  # spin-up under way; the full 500 s adds nothing here
    if name.startswith("orbit_"):
        overrides.append("sim.duration_s=600")  # a held attitude: its commands are small and alike all orbit long
    result = run_scenario(load_scenario(name, overrides), None)
    assert result.status == "ok", result.error
    m = result.metrics
    assert m["gimbal_angle_limit_violations"] == 0 and m["gimbal_acceleration_violations"] == 0
    assert m["rate_limit_violations"] == 0
    assert m["peak_gimbal_acceleration_deg_s2"] <= 100 * (1 + 1e-9)
    # the measured angle: the servo's compliance (intvelocity), or, for the feedforward servo, which
    # reaches each command only at the end of its tick, a lag of half a tick per rate change: through
    # a stop's braking, at most beta'max Tc / 2 (measured 0.16 deg at 10 deg/s, 0.11 deg at 30 deg/s)
    lag = (scenario.stages["allocator"][1].beta_rate_max_deg_s * scenario.sim.control_period_s / 2
           if scenario.model.servo_model == "feedforward" else 0.0)
    assert m["min_gimbal_angle_margin_deg"] > -0.01 - lag
