"""The flagship's stages on many worlds at once (rate gyro, Lebedev observer and law: their batched
forms, testbed.batch.stage_forms) against the same worlds run one by one.

Independent numbers: each world's own single run, and each world's own gyro stepped alone. The
forms compute each row with the single stage's own elementwise functions in the same order, so
the gyro's samples are compared to the bit; whole runs are compared with `agree` (BATCHED_REL of
tests/test_batch_lockstep.py: the metrics are end errors and drifts of well-conditioned runs, a
few ulps of the state amplified by at most the run's length), the contract a batched allocator
may also be held to.
"""

from __future__ import annotations

import numpy as np
import pytest

import testbed
from testbed.batch import Batch
from testbed.batch.stage_forms import PerWorld
from testbed.lebedev.batched import LebedevEstimates, LebedevTorques
from testbed.lebedev.observer import gyrostat_jacobian
from testbed.lebedev.validity import is_hurwitz
from testbed.pipeline import StageContext
from testbed.run_core.plan import prepare
from testbed.scenario import schema
from testbed.stages.rate_gyro import RateGyro, RateGyroParams, RateGyros
from test_batch_lockstep import agree


def _unit(v) -> list:
    v = np.asarray(v, float)
    return (v / np.linalg.norm(v)).tolist()


# flagship worlds not in the repository: other buses (inertia within the design's reach), gyro
# axes, noises and seeds, initial rates, one with the interpolated measurement hold
WORLDS = [
    dict(inertia=[1200.0, 7000.0, 7150.0], axis=[1.0, 1.0, 1.0], omega=[0.3, -0.2, 0.1], sigma=0.0, seed=0,
         bias=0.0, hold="zero_order"),
    dict(inertia=[1280.0, 6800.0, 7000.0], axis=[1.0, 1.1, 0.95], omega=[0.1, 0.15, -0.05], sigma=2e-6, seed=91,
         bias=3e-6, hold="zero_order"),
    dict(inertia=[1239.575, 6894.557, 7084.538], axis=[0.9, 1.0, 1.1], omega=[-0.2, -0.3, 0.0], sigma=1e-6,
         seed=4_000_000_001, bias=-1e-5, hold="linear"),
    dict(inertia=[1250.0, 6950.0, 7050.0], axis=[1.05, 0.95, 1.0], omega=[0.0, 0.05, 0.2], sigma=5e-7, seed=7,
         bias=0.0, hold="zero_order"),
]


def _world(world: dict, duration: float):
    return testbed.load("lebedev_spinup_cmg", [
        f"sim.duration_s={duration}", "model.cancel_initial_momentum=true",
        f"model.inertia_kg_m2={world['inertia']}", f"initial.omega_deg_s={world['omega']}",
        f"pipeline.sensor.axis={_unit(world['axis'])}", f"pipeline.sensor.noise_sigma_rad_s={world['sigma']}",
        f"pipeline.sensor.seed={world['seed']}", f"pipeline.sensor.bias_rad_s={world['bias']}",
        f"pipeline.estimator.measurement_hold={world['hold']}"])


def _batched(scenarios):
    with Batch([prepare(scenario) for scenario in scenarios]) as batch:
        forms = {slot: type(form) for slot, form in batch.forms.items()}
        batch.advance(batch.timing.n_ticks)
        return forms, batch.finish()


def test_flagship_worlds_in_a_batch_are_each_world_run_alone():
    """Four worlds past the start-up (150 s), so both the open (eq. 3.1) and the closed observer
    (eq. 4.6) and the validity test run batched: each world's result is its single run's."""
    scenarios = [_world(world, 175.0) for world in WORLDS]
    singles = [testbed.run(scenario) for scenario in scenarios]
    forms, batched = _batched(scenarios)
    assert (forms["sensor"], forms["estimator"], forms["law"]) == (RateGyros, LebedevEstimates, LebedevTorques)
    for single, world in zip(singles, batched):
        assert single.status == "ok"
        agree(single, world)
    # the worlds differ: a batch that handed one world's numbers to another would not pass above
    assert len({r.metrics["estimation_error_final_deg_s"] for r in batched}) == len(WORLDS)


def test_a_world_whose_observer_leaves_its_validity_leaves_the_batch_alone():
    """The campaign's w_y(0) = 0.4 deg/s start (tests/test_lebedev_validity.py: method_failed at
    159.3 s) among two worlds that converge: it leaves with its single run's status, error and
    time; the others run to the end."""
    rates = ([0.25, 0.4, 0.0], [0.2, -0.3, 0.1], [-0.1, 0.1, 0.0])
    scenarios = [testbed.load("lebedev_spinup_campaign", ["sim.duration_s=170", f"initial.omega_deg_s={list(w)}"])
                 for w in rates]
    singles = [testbed.run(scenario) for scenario in scenarios]
    forms, batched = _batched(scenarios)
    assert forms["estimator"] is LebedevEstimates
    assert [r.status for r in singles] == ["method_failed", "ok", "ok"]
    for single, world in zip(singles, batched):
        agree(single, world)
    assert "the observer diverged" in batched[0].error
    assert batched[0].sim_s == singles[0].sim_s < batched[1].sim_s == batched[2].sim_s


class _Body:
    def __init__(self, omega):
        self.w = np.asarray(omega, float)

    def omega(self):
        return self.w


def _gyro(params: dict, control: float = 0.05) -> RateGyro:
    p = schema.load(RateGyroParams, params, "pipeline.sensor")
    return RateGyro(p, StageContext(dt=0.01, control_period=control, inertia=np.eye(3)))


def test_the_gyros_form_gives_each_world_its_own_samples_to_the_bit():
    """Gyros of other axes, biases, noises (one noise-free), quantisation and sample periods, read
    for longer than a block of noise draws: each row is what its own gyro reads alone, bit for bit
    (its own generator, drawn in blocks, gives the same sequence)."""
    params = [dict(axis=_unit([1, 2, 3]), noise_sigma_rad_s=1e-3, seed=5),
              dict(axis=_unit([0, 0, 1]), noise_sigma_rad_s=0.0, bias_rad_s=1e-4),
              dict(axis=_unit([-1, 1, 0.5]), noise_sigma_rad_s=2e-4, seed=2**32 - 1, quantisation_rad_s=1e-4),
              dict(axis=_unit([1, 1, 1]), noise_sigma_rad_s=1e-4, seed=5, sample_period_s=0.15)]
    alone, together = [_gyro(p) for p in params], [_gyro(p) for p in params]
    form = RateGyro.batched(together)
    rng = np.random.default_rng(11)
    ticks = 3 * RateGyros.NOISE_BLOCK + 17
    drawn = 0
    for k in range(ticks):
        bodies = [_Body(rng.normal(scale=0.02, size=3)) for _ in params]
        rows = form.measure(k * 0.05, bodies)
        for row, (gyro, body) in enumerate(zip(alone, bodies)):
            own = gyro.measure(k * 0.05, body)
            assert rows["y"][row].tobytes() == own["y"].tobytes() and rows["stamp"][row] == own["stamp"]
        drawn += int(rows["stamp"][3, 0] == k * 0.05)
    assert drawn == len(range(0, ticks, 3))   # the slow gyro sampled every third tick
    # a world leaving keeps the others' sequences
    form.keep(np.array([0, 2]))
    body = _Body([0.01, 0.02, 0.03])
    rows = form.measure(ticks * 0.05, [body, body])
    assert rows["y"][0] == alone[0].measure(ticks * 0.05, body)["y"]
    assert rows["y"][1] == alone[2].measure(ticks * 0.05, body)["y"]


def test_the_validity_test_on_a_stack_is_each_matrix_alone():
    """`gyrostat_jacobian` and `is_hurwitz` on a batch's stack (per-world moments) give each
    world's own matrix and verdict, bit for bit; the verdicts checked against the eigenvalues."""
    rng = np.random.default_rng(23)
    moments = rng.uniform(1000.0, 8000.0, size=(400, 3))
    w, momentum = rng.normal(scale=0.05, size=(400, 3)), rng.normal(scale=100.0, size=(400, 3))
    jacobians = gyrostat_jacobian(moments, w, momentum)
    shift = rng.uniform(0.0, 0.05, size=(400, 1, 1)) * np.eye(3)   # both signs of stability represented
    verdicts = is_hurwitz(jacobians - shift)
    for k in range(len(moments)):
        alone = gyrostat_jacobian(moments[k], w[k], momentum[k])
        assert jacobians[k].tobytes() == alone.tobytes()
        assert verdicts[k] == is_hurwitz(alone - shift[k]) == (np.linalg.eigvals(alone - shift[k]).real.max() < 0.0)
    assert 0 < verdicts.sum() < len(moments)


def test_measured_momentum_observers_run_per_world_beside_the_batched_gyro_and_law():
    """The measured-momentum observer (its information filter and held command its own stage's)
    has no batched form: its slot runs per world, the gyro and the law batched around it, and
    each world is still its single run."""
    scenarios = [testbed.load("lebedev_spinup_cmg_momentum",
                              ["sim.duration_s=20", f"initial.omega_deg_s=[{w}, -0.2, 0.1]"]) for w in (0.2, 0.35)]
    singles = [testbed.run(scenario) for scenario in scenarios]
    forms, batched = _batched(scenarios)
    assert (forms["sensor"], forms["estimator"], forms["law"]) == (RateGyros, PerWorld, LebedevTorques)
    for single, world in zip(singles, batched):
        agree(single, world)


def test_worlds_whose_observers_close_the_loop_at_different_times_are_refused_together():
    """Before its start-up ends an observer withholds `omega`: worlds closing at different times
    would give the law rows of different keys, so the batch refuses them, naming the field."""
    plans = [prepare(testbed.load("lebedev_spinup_cmg", ["sim.duration_s=1", f"pipeline.estimator.startup_s={s}"]))
             for s in (150, 120)]
    with pytest.raises(ValueError, match="startup_s: batch them apart"):
        Batch(plans)
