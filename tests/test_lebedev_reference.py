"""Issue 16, part 1: the continuous-time closed loop of Lebedev (1976) as the reference
`lebedev_continuous` and the metric `max_deviation_from_continuous_deg_s`.

Independent numbers: a second, separately written continuous solution of the paper's example
(tests/test_lebedev_stages.py), the SEEDS §000 measurements, the Jacobi-elliptic closed form of
the torque-free start-up leg, conservation of |I w + H| with an internal actuator, and the
sampled loop's first-order convergence to the reference on a case that is not in the repository.
"""

import numpy as np
import pytest

from testbed.errors import InputError
from testbed.lebedev.continuous import closed_loop_states
from testbed.references.torque_free import torque_free_omega
from testbed.runner import prepare, run_scenario
from testbed.scenario.loading import load_scenario
from testbed.lebedev.stage import LebedevEstimator
from test_lebedev_stages import _paper_loop_continuous

DEG = np.pi / 180
CONTINUOUS = "reference={type: lebedev_continuous}"
# A case not in the repository: other inertia, gyro axis, poles, gains and Omega.
OTHER_CASE = """name: other_case
description: a small satellite spun up to 2 deg/s from a skewed gyro
model: {system: satellite, inertia_kg_m2: [300, 500, 600], mass_kg: 200}
initial: {omega_deg_s: [0.3, -0.2, 0.5]}
sim: {duration_s: 120, dt_s: 0.02, control_period_s: 0.02, trace_period_s: 0.2}
pipeline:
  sensor: {type: rate_gyro, axis: [0.3, 0.5, 0.8124038404635961]}
  estimator: {type: lebedev, poles_per_s: [-0.2, -0.25, -0.3], startup_s: 60}
  law: {type: lebedev, task: spin, spin_rate_deg_s: 2.0, gains_per_s: [-0.5, -0.5, -0.5]}
  allocator: {type: ideal_torque}
reference: {type: lebedev_continuous}
"""


def _reference(name, times, overrides=()):
    plant, _, evaluate = prepare(load_scenario(name, [CONTINUOUS, *overrides]))
    return plant, evaluate(np.asarray(times, float), None)


def test_reference_is_the_paper_loop_and_the_seed_numbers():
    times = np.arange(0.0, 1000.01, 0.5)
    _, omega = _reference("lebedev_spinup_ideal", times)
    _, loop = _paper_loop_continuous(1000.0)
    after = times >= 150.0
    # At the round-off floor: two writings of one loop and one ODE solve differ by round-off
    # (1.7e-12 rad/s under one OpenBLAS kernel, below 1e-12 under another); 1e-10 rad/s is 6e-9
    # of the 1 deg/s spin, far below the seed's figures checked next.
    assert np.max(np.abs(omega[after] - loop.sol(times[after])[:3].T)) < 1e-10   # rad/s
    # SEEDS §000: (0.0002, 0.0016, 0.998) deg/s at 600 s, within 1e-6 deg/s at 700 s, 1e-10 at 800 s
    x = lambda t: omega[np.flatnonzero(times == t)[0]] / DEG - [0.0, 0.0, 1.0]  # noqa: E731
    assert np.all(np.abs(x(600.0) + [0, 0, 1] - [0.0002, 0.0016, 0.998]) <= [5e-5, 5e-5, 5e-4])
    # (measured 7.6e-7 and 1.04e-10 per component: the seed's one printed digit)
    assert np.max(np.abs(x(700.0))) < 1.5e-6 and np.max(np.abs(x(800.0))) < 1.5e-10


def test_startup_leg_is_the_torque_free_closed_form():
    times = np.linspace(0.0, 149.5, 300)
    plant, omega = _reference("lebedev_spinup_ideal", times)
    exact = torque_free_omega(np.diag(plant.locked_inertia()), plant.omega(), times)
    assert np.max(np.abs(omega - exact)) < 1e-12


def test_internal_momentum_keeps_the_total_and_refuses_other_stages():
    """With a CMG cluster the continuous loop exchanges momentum between bus and cluster: the
    total in body axes, I w + H, keeps its length (it only turns with the body)."""
    scenario = load_scenario("lebedev_spinup_cmg", [CONTINUOUS])
    plant, _, evaluate = prepare(scenario)
    sensor, est, law = (scenario.stages[slot][1] for slot in ("sensor", "estimator", "law"))
    obs = LebedevEstimator.build_observer(est, plant.locked_inertia(), law.omega_ref, sensor.axis)
    times = np.linspace(0.0, 500.0, 1001)
    states = closed_loop_states(obs, law.gains_per_s, est.startup_s, plant.omega(), plant.internal_momentum_body(),
                                times, internal=True)
    assert np.array_equal(evaluate(times, None), states[:, :3])
    total = obs.inertia * states[:, :3] + states[:, 6:]
    stored = np.linalg.norm(states[-1, 6:])
    assert np.linalg.norm(total[0]) < 1e-3 * stored            # a zero-momentum spacecraft ...
    assert np.max(np.linalg.norm(total, axis=1)) < 1e-8 * stored  # ... stays one
    assert states[-1, 8] == pytest.approx(-obs.inertia[2] * law.omega_ref, rel=1e-6)
    with pytest.raises(InputError, match="reference.type"):
        prepare(load_scenario("lebedev_spinup_ideal", [CONTINUOUS, "pipeline.law={type: none}",
                                                       "pipeline.estimator={type: none}", "checks={}"]))


@pytest.mark.slow
def test_sampled_loop_converges_to_it_at_first_order(tmp_path):
    """A case not in the repository (other inertia, gyro axis, poles, gains, Omega): the sampled
    loop's deviation from the reference halves with the period (measured 0.5127, 0.2538, 0.1263
    deg/s at 0.04, 0.02, 0.01 s over 400 s), so its limit, the reference, is the continuous loop:
    extrapolated to period 0 (Richardson) the deviation vanishes to a few % of the sampled one."""
    case = tmp_path / "other_case.yaml"
    case.write_text(OTHER_CASE)
    deviation = {}
    for hold in ("zero_order", "linear"):
        for h in (0.02, 0.01):
            run = run_scenario(load_scenario(str(case), [f"sim.dt_s={h}", f"sim.control_period_s={h}",
                                                         f"pipeline.estimator.measurement_hold={hold}"]), None)
            assert run.status == "ok"
            deviation[hold, h] = run.metrics["max_deviation_from_continuous_deg_s"]
        assert deviation[hold, 0.02] / deviation[hold, 0.01] == pytest.approx(2.0, rel=0.03)
        assert abs(2 * deviation[hold, 0.01] - deviation[hold, 0.02]) < 0.03 * deviation[hold, 0.01]
    assert 0.2 < deviation["zero_order", 0.02] < 0.3   # measured 0.2538: holding y is first order ...
    # ... and so is the linear hold, but 86 times smaller (measured 0.00294): what is left is the
    # law's torque held over the period
    assert deviation["linear", 0.02] < deviation["zero_order", 0.02] / 50
