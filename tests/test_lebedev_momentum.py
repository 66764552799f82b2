"""Issue 16, part 4: one gyro on a spacecraft with non-zero total momentum.

Independent numbers: Euler's equations of the free gyrostat (the start-up model must be their
exact linear part), numpy's eigenvalues (the scheduled gain must place the poles), numerical
determinants on random bodies, gyro axes and momenta (the axial closed form and the radius r*
derived in testbed/observers/lebedev_momentum.py), and Lebedev's eq. 4.5 for H = 0.
"""

import numpy as np
import pytest

from testbed.cli import main
from testbed.errors import InputError
from testbed.observers.lebedev_momentum import (
    axial_unobservable_momenta,
    end_state_margin,
    observability_determinant,
    observable_momentum_radius,
)
from testbed.observers.lebedev_observer import LebedevObserver, lebedev_nonlinearity, observability_factor

DEG = np.pi / 180
SKYLAB_1000 = np.array([1250.0, 6900.0, 7100.0])
PAPER_AXIS = np.ones(3) / np.sqrt(3)


def _random_case(rng):
    """A body with Ix < Iy < Iz (triangle inequality kept), a gyro axis, a spin rate."""
    ix, iy = np.sort(rng.uniform(0.3, 1.0, 2))
    inertia = np.array([ix, iy, 1.0]) * rng.uniform(10, 1e4)
    if inertia[0] + inertia[1] <= inertia[2]:
        inertia[2] = 0.95 * (inertia[0] + inertia[1])
        inertia = np.sort(inertia)
    axis = rng.normal(size=3)
    return inertia, axis / np.linalg.norm(axis), rng.uniform(0.2, 3.0) * DEG * rng.choice([-1, 1])


def test_zero_internal_momentum_is_the_paper():
    """H = 0 means L = I Omega e_z: det W is Lebedev's eq. 4.5."""
    rng = np.random.default_rng(16)
    for _ in range(20):
        inertia, axis, spin = _random_case(rng)
        paper = observability_factor(inertia, spin, axis)
        assert observability_determinant(inertia, spin, axis, [0, 0, inertia[2] * spin]) == pytest.approx(
            paper, rel=1e-9, abs=1e-12 * abs(paper))


def test_axial_closed_form_on_random_bodies():
    rng = np.random.default_rng(4)
    for _ in range(20):
        inertia, (alpha, beta, gamma), spin = _random_case(rng)
        ix, iy, _ = inertia
        for L3 in rng.uniform(-3, 3, 5) * inertia[2] * abs(spin):
            closed = gamma * (ix * spin - L3) * (iy * spin - L3) * (
                ix * (ix * spin - L3) * beta**2 + iy * (iy * spin - L3) * alpha**2) / (ix**2 * iy**2)
            numeric = observability_determinant(inertia, spin, [alpha, beta, gamma], [0, 0, L3])
            assert numeric == pytest.approx(closed, rel=1e-8, abs=1e-14 * abs(closed) + 1e-300)
        scale = abs(observability_determinant(inertia, spin, [alpha, beta, gamma], [0, 0, 0]))
        for L3 in axial_unobservable_momenta(inertia, spin, [alpha, beta, gamma]):
            assert abs(observability_determinant(inertia, spin, [alpha, beta, gamma], [0, 0, L3])) < 1e-9 * scale


def test_radius_is_the_nearest_unobservable_momentum():
    r, nearest = observable_momentum_radius(SKYLAB_1000, DEG, PAPER_AXIS)
    assert r == pytest.approx(15.38, abs=0.01)          # the flagship's spacecraft (README)
    assert r < SKYLAB_1000[0] * DEG                      # nearer than the axial zero at Ix Omega
    d0 = observability_determinant(SKYLAB_1000, DEG, PAPER_AXIS, np.zeros(3))
    assert abs(observability_determinant(SKYLAB_1000, DEG, PAPER_AXIS, nearest)) < 1e-6 * abs(d0)
    rng = np.random.default_rng(1)
    inside = rng.normal(size=(20000, 3))
    inside *= (0.99 * r * rng.uniform(0, 1, (20000, 1)) ** (1 / 3)) / np.linalg.norm(inside, axis=1, keepdims=True)
    assert np.all(np.sign(observability_determinant(SKYLAB_1000, DEG, PAPER_AXIS, inside)) == np.sign(d0))


def test_startup_model_is_the_free_gyrostat_and_gains_place_the_poles():
    rng = np.random.default_rng(7)
    poles = [-0.1, -0.12, -0.15]
    for _ in range(10):
        inertia, axis, spin = _random_case(rng)
        observer = LebedevObserver(inertia, spin, axis, poles, measured_momentum=True)
        held = rng.normal(size=3) * 0.2 * inertia[2] * abs(spin)
        matrix, drift, gain = observer.startup_model(held)
        x = rng.normal(size=3) * abs(spin)
        w = x + [0, 0, spin]
        euler = -np.cross(w, inertia * w + held) / inertia        # I w' = -w x (I w + H)
        assert matrix @ x + drift + lebedev_nonlinearity(observer.a, x) == pytest.approx(euler, rel=1e-9, abs=1e-15)
        assert np.sort(np.linalg.eigvals(matrix - np.outer(gain, axis)).real) == pytest.approx(np.sort(poles), abs=1e-6)
        z = rng.normal(size=3) * 0.1 * abs(spin)
        closed = observer.closed_gain(held, z)
        end = held + inertia * z                                    # the H held at the wanted spin
        A_end = observer.startup_model(end)[0]
        assert np.sort(np.linalg.eigvals(A_end - np.outer(closed, axis)).real) == pytest.approx(np.sort(poles), abs=1e-6)
    # a fixed-gain observer ignores H, as before
    fixed = LebedevObserver(SKYLAB_1000, DEG, PAPER_AXIS, poles)
    assert np.array_equal(fixed.closed_gain(np.ones(3)), fixed.l)
    # at an unobservable operating point no gain exists: the run stops there (stage error)
    unobservable = np.array([0.0, 0.0, SKYLAB_1000[0] * DEG]) - [0, 0, SKYLAB_1000[2] * DEG]
    with pytest.raises(InputError, match="unobservable"):
        LebedevObserver(SKYLAB_1000, DEG, PAPER_AXIS, poles, measured_momentum=True).gain_for(unobservable)


def test_end_state_margin_and_the_load_time_refusal(tmp_path, capsys):
    # the shipped stored-momentum case: L mostly against the spin, every end state well observable
    margin, _ = end_state_margin(SKYLAB_1000, DEG, PAPER_AXIS, [20.0, -15.0, -60.0])
    assert margin > 1.0
    # the same |L| along the spin crosses det W = 0 on its end circle
    assert end_state_margin(SKYLAB_1000, DEG, PAPER_AXIS, [20.0, -15.0, 60.0])[0] < 0
    out = tmp_path / "x.rrd"
    code = main(["run", "lebedev_spinup_cmg_momentum", "--out", str(out),
                 "--set", "initial.omega_deg_s=[0.25, -0.25, 0.8]"])   # L = (20, -15, 39) N m s
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and err.startswith("error: initial: total angular momentum")
    assert not out.exists()


@pytest.mark.slow
def test_stored_momentum_scenario_spins_up_from_one_gyro():
    """The shipped scenario passes the flagship's checks with 22 % of the cluster's capacity stored;
    the spin axis tilts against L by far less than the 15 deg the load-time check allows."""
    from testbed.runner import prepare, run_scenario
    from testbed.scenario import load_scenario

    scenario = load_scenario("lebedev_spinup_cmg_momentum")
    run = run_scenario(scenario, None, keep_data=True)
    assert run.status == "ok" and run.passed, run.checks
    rec = run.data.recorder
    plant, _, _ = prepare(scenario)
    capacity = 4 * scenario.model.rotor_momentum_nms              # the envelope's reach along z
    L_world = rec["truth/angular_momentum_world"]
    assert np.linalg.norm(L_world[0]) >= 0.2 * capacity
    assert run.metrics["momentum_drift_rel"] < 1e-8                 # of the 300 N m s in the rotors
    body = np.diag(plant.locked_inertia()) * rec["truth/omega"] + rec["truth/cmg_momentum"]   # L in body axes
    tilt = np.degrees(np.arccos(body[[0, -1], 2] / np.linalg.norm(body[[0, -1]], axis=1)))
    assert abs(tilt[1] - tilt[0]) < 5.0                            # measured 3.2 deg
