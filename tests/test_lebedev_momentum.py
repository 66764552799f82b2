"""Issue 16, part 4: one gyro on a spacecraft with non-zero total momentum.

Independent numbers: Euler's equations of the free gyrostat (the start-up model must be their
exact linear part), numpy's eigenvalues (the scheduled gain must place the poles), numerical
determinants on random bodies, gyro axes and momenta (the axial closed form and the radius r*
derived in testbed/lebedev/momentum.py), and Lebedev's eq. 4.5 for H = 0.
"""

import numpy as np
import pytest

from testbed.cli import main
from testbed.errors import InputError
from testbed.math.information_filter import filter_gain, gathered_information, information_rate
from testbed.lebedev.momentum import (
    CLOSED_LOOP_TILT_DEG,
    axial_unobservable_momenta,
    end_state_information,
    idle_polar_angles,
    observability_determinant,
    observable_momentum_radius,
)
from testbed.lebedev.observer import (
    LebedevObserver,
    gyrostat_error_matrix,
    gyrostat_jacobian,
    lebedev_matrices,
    lebedev_nonlinearity,
    observability_factor,
)

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
    assert r == pytest.approx(15.38, abs=0.01)          # the flagship's spacecraft (docs/theory/lebedev.md)
    assert r < SKYLAB_1000[0] * DEG                      # nearer than the axial zero at Ix Omega
    d0 = observability_determinant(SKYLAB_1000, DEG, PAPER_AXIS, np.zeros(3))
    assert abs(observability_determinant(SKYLAB_1000, DEG, PAPER_AXIS, nearest)) < 1e-6 * abs(d0)
    rng = np.random.default_rng(1)
    inside = rng.normal(size=(20000, 3))
    inside *= (0.99 * r * rng.uniform(0, 1, (20000, 1)) ** (1 / 3)) / np.linalg.norm(inside, axis=1, keepdims=True)
    assert np.all(np.sign(observability_determinant(SKYLAB_1000, DEG, PAPER_AXIS, inside)) == np.sign(d0))


def test_startup_model_and_jacobian_are_the_free_gyrostat():
    """The start-up model with F(z) is Euler's equations of the body holding H, and the filter's
    linearisation J(w, H) is their derivative (central differences)."""
    rng = np.random.default_rng(7)
    for _ in range(10):
        inertia, axis, spin = _random_case(rng)
        observer = LebedevObserver(inertia, spin, axis, [-0.1, -0.12, -0.15], measured_momentum=True)
        held = rng.normal(size=3) * 0.2 * inertia[2] * abs(spin)
        matrix, drift = observer.startup_model(held)
        x = rng.normal(size=3) * abs(spin)
        w = x + [0, 0, spin]
        euler = lambda w: -np.cross(w, inertia * w + held) / inertia     # noqa: E731  I w' = -w x (I w + H)
        assert matrix @ x + drift + lebedev_nonlinearity(observer.a, x) == pytest.approx(euler(w), rel=1e-9, abs=1e-15)
        step = 1e-6 * abs(spin)
        numeric = np.column_stack([(euler(w + step * e) - euler(w - step * e)) / (2 * step) for e in np.eye(3)])
        assert gyrostat_jacobian(inertia, w, held) == pytest.approx(numeric, rel=1e-6, abs=1e-9 * np.abs(numeric).max())
        # at the spin: the paper's A (Lebedev 1976, eq. 4.2) plus I^-1 [H x], [H x] v = H x v
        _, paper_A = lebedev_matrices(inertia, spin)
        cross = np.column_stack([np.cross(held, e) for e in np.eye(3)])
        assert gyrostat_error_matrix(inertia, spin, held) == pytest.approx(
            paper_A + cross / inertia[:, None], rel=1e-12, abs=1e-15 * np.abs(paper_A).max())
        stack = rng.normal(size=(4, 3)) * held
        assert np.array_equal(gyrostat_error_matrix(inertia, spin, stack),
                              np.stack([gyrostat_error_matrix(inertia, spin, h) for h in stack]))
        ws = w + rng.normal(size=(4, 3)) * abs(spin)
        assert np.array_equal(gyrostat_jacobian(inertia, ws, stack),
                              np.stack([gyrostat_jacobian(inertia, v, h) for v, h in zip(ws, stack)]))
    # a fixed-gain observer ignores H, as before
    fixed = LebedevObserver(SKYLAB_1000, DEG, PAPER_AXIS, [-0.1, -0.1, -0.1])
    z = np.array([1e-3, -2e-3, 5e-4])
    assert np.array_equal(fixed.closed_derivative(z, 0.0, np.zeros(3), np.ones(3)),
                          fixed.closed_derivative(z, 0.0, np.zeros(3)))


def test_held_command_model_is_the_body_under_that_command():
    """Once the loop is closed the cluster holds H' = -(M + w_k x H_k) over the period; the body
    then obeys I w' = -w x (I w + H) - H' (momentum balance of bus and rotors). With a perfect
    estimate (z = x, no innovation) the observer's model must be exactly that derivative, for
    every H(t) = H_k + (t - t_k) H' the period passes through."""
    rng = np.random.default_rng(11)
    for _ in range(10):
        inertia, axis, spin = _random_case(rng)
        observer = LebedevObserver(inertia, spin, axis, [-0.1, -0.1, -0.1], measured_momentum=True)
        held = rng.normal(size=3) * 0.3 * inertia[2] * abs(spin)
        observer.start(held)
        w_k = rng.normal(size=3) * abs(spin)
        torque = rng.normal(size=3) * inertia * spin**2
        rate = -(torque + np.cross(w_k, held))                       # H' the steering commands
        for elapsed in (0.0, 0.02, 0.05):
            momentum = held + elapsed * rate
            w = w_k + rng.normal(size=3) * 0.1 * abs(spin)
            x = w - [0, 0, spin]
            truth = (-np.cross(w, inertia * w + momentum) - rate) / inertia
            state = np.concatenate([x, observer.info.ravel()])
            model = observer.closed_derivative(state, axis @ x, torque / inertia, momentum, np.cross(w_k, held))
            # round-off band: a component that nearly cancels carries the round-off of the largest
            # (measured up to 1.8e-12 of it, by CPU); a missing or wrong term is 1e-3 of it or more
            assert model[:3] == pytest.approx(truth, rel=1e-9, abs=1e-10 * np.abs(truth).max())


def test_information_filter_decays_at_its_rate_on_a_time_varying_pair():
    """V = e' Pi e falls at least as e^(-2 a t) for any A(t) (testbed.math.information_filter),
    checked by integrating e' = (A - l c') e and Pi together with SciPy on a pair whose
    det [c; c A; c A^2] changes sign; and the steady filter of the paper's pair puts the
    error poles 2a left of eig(A), the designed -0.1 1/s for a = 0.05."""
    from scipy.integrate import solve_ivp
    from scipy.linalg import solve_continuous_lyapunov

    c, a = PAPER_AXIS, 0.05
    A0 = LebedevObserver(SKYLAB_1000, DEG, PAPER_AXIS, [-0.1] * 3).A
    def A(t):   # the flagship's error matrix with an H turning at 1 deg/s (det W changes sign)
        held = 60 * np.array([np.cos(DEG * t), np.sin(DEG * t), 0.3])
        return gyrostat_error_matrix(SKYLAB_1000, DEG, held)
    dets = [np.linalg.det(np.vstack([c, c @ A(t), c @ A(t) @ A(t)])) for t in range(0, 360, 5)]
    assert min(dets) < 0 < max(dets)

    def rhs(t, s):
        e, info = s[:3], s[3:].reshape(3, 3)
        return np.concatenate([(A(t) - np.outer(filter_gain(info, c), c)) @ e,
                               information_rate(A(t), info, a, c).ravel()])
    info0 = gathered_information(A(0), a, c, 100.0)
    e0 = np.array([1.0, -2.0, 0.5]) * DEG
    times = np.linspace(0, 400, 81)
    sol = solve_ivp(rhs, (0, 400), np.concatenate([e0, info0.ravel()]), rtol=1e-10, atol=1e-16, t_eval=times)
    V = np.array([s[:3] @ s[3:].reshape(3, 3) @ s[:3] for s in sol.y.T])
    assert np.all(V <= V[0] * np.exp(-2 * a * times) * (1 + 1e-6))
    steady = solve_continuous_lyapunov((A0 + a * np.eye(3)).T, np.outer(c, c))
    poles = np.linalg.eigvals(A0 - np.outer(filter_gain(steady, c), c))
    assert poles.real == pytest.approx([-2 * a] * 3, abs=1e-9)
    assert np.sort(np.abs(poles.imag)) == pytest.approx(np.sort(np.abs(np.linalg.eigvals(A0).imag)), abs=1e-9)


def test_end_state_information_and_the_load_time_refusal(tmp_path, capsys):
    decay = 0.05
    # the shipped stored-momentum case: far more information than the rigid body's
    assert end_state_information(SKYLAB_1000, DEG, PAPER_AXIS, [20.0, -15.0, -60.0], decay) > 10
    # an axial total momentum at an unobservable value (closed form) leaves the filter nothing
    for L3 in axial_unobservable_momenta(SKYLAB_1000, DEG, PAPER_AXIS):
        assert abs(end_state_information(SKYLAB_1000, DEG, PAPER_AXIS, [0.0, 0.0, L3], decay)) < 1e-3
    # the shipped gimbals with w(0) chosen so that L = (0, 0, 105.3) N m s: refused before the run
    held = np.array([20.0, -15.0, -60.0]) - SKYLAB_1000 * np.radians([0.25, -0.25, 0.0])
    omega0 = np.degrees((np.array([0.0, 0.0, axial_unobservable_momenta(SKYLAB_1000, DEG, PAPER_AXIS)[2]]) - held)
                        / SKYLAB_1000)
    out = tmp_path / "x.rrd"
    code = main(["run", "lebedev_spinup_cmg_momentum", "--out", str(out),
                 "--set", f"initial.omega_deg_s=[{', '.join(f'{v:.6f}' for v in omega0)}]"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and err.startswith("error: initial: total angular momentum")
    assert not out.exists()


@pytest.mark.slow
def test_stored_momentum_scenario_spins_up_from_one_gyro():
    """The shipped scenario passes the flagship's checks with 22 % of the cluster's capacity stored;
    L's angle to body z at the end lies within the load-time check's band: the range the idle
    start-up sweeps (solved independently of the run) widened by CLOSED_LOOP_TILT_DEG."""
    from testbed.runner import prepare, run_scenario
    from testbed.scenario.loading import load_scenario

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
    polar = np.degrees(np.arccos(body[:, 2] / np.linalg.norm(body, axis=1)))
    at_closing = polar[np.searchsorted(rec.time, scenario.stages["estimator"][1].startup_s)]
    assert abs(polar[-1] - at_closing) < CLOSED_LOOP_TILT_DEG       # measured 1.1 deg (20.1 deg while idle)
    idle = idle_polar_angles(np.diag(plant.locked_inertia()), plant.internal_momentum_body(),
                             np.radians(scenario.initial.omega_deg_s), 150.0)
    low, high = idle.min(), idle.max()
    assert low - CLOSED_LOOP_TILT_DEG <= polar[-1] <= high + CLOSED_LOOP_TILT_DEG


@pytest.mark.slow
@pytest.mark.parametrize(("gimbal_angles_deg", "overrides"), [
    # (two more, |L| = 115 and 159 N m s at 128 and 154 deg to the spin, are cases 1 and 6 of
    # `bench/lebedev_momentum_boundary.py --cases 50 --seed 16`: a study, not the suite's)
    ([30.0, -20.0, 10.0, 60.0], []),                 # L = (-18.7, -10.5, -66.1) N m s: 57.8 deg/s off with the old start-up
    # steady errors before the observer kept L_b = I w_hat + H (spin, estimation error [deg/s]):
    ([-124.199908, 68.983112, 165.108179, 174.594596], []),   # seed 16 case 3: 4.8e-3, 1.5e-2 -> 3.4e-5, 2.2e-4
    ([-36.249923, 78.269285, -78.903602, -150.219030],        # seed 18 case 0: 3.3e-3, 3.3e-3 -> 1.8e-5, 1.2e-4
     ["model.inertia_kg_m2=[1800, 4500, 5200]"]),
])
def test_stored_momenta_not_shipped_pass_the_scenario_checks(gimbal_angles_deg, overrides):
    """Off-repo stored momenta the load-time check accepts: the scenario's own check bounds on
    the spin and estimation errors hold, and the estimate has converged when control starts."""
    from testbed.runner import run_scenario
    from testbed.scenario.loading import load_scenario

    scenario = load_scenario("lebedev_spinup_cmg_momentum",
                             [f"model.gimbal_angles_deg=[{', '.join(map(str, gimbal_angles_deg))}]", *overrides])
    run = run_scenario(scenario, None)
    assert run.status == "ok"
    bounds = scenario.checks
    for name in ("spin_error_final_deg_s", "estimation_error_final_deg_s"):
        assert run.metrics[name] <= bounds[name].max, name
    assert run.metrics["estimation_error_at_closing_deg_s"] < 0.01   # the old start-up: 3.8 deg/s on the first


def _estimate_under_exchange(jump, exchange_rate, reanchor: bool, duration=160.0):
    """Rate-estimate errors [rad/s] of the measured-momentum estimator stage, started at the truth,
    on a free bus whose cluster follows the steering's held command H' = -(M + w_k x H_k) (M = 0)
    plus a momentum exchange the command does not contain: a step `jump` [N m s] at t = 40 s
    (the bus takes -jump: L_b is kept) and a steady `exchange_rate` [N m] from t = 100 s. The
    truth is Euler's equations of the bus holding H, I w' = -w x (I w + H) - H' (RK4, two
    substeps a period); the stage gets y = p . w and the H measured at each sample.
    `reanchor` False: the same observer without LebedevObserver.hold_total_momentum (before)."""
    from testbed.runner import prepare
    from testbed.scenario.loading import load_scenario

    scenario = load_scenario("lebedev_spinup_cmg_momentum", ["pipeline.estimator.startup_s=0.05"])
    _, pipeline, _ = prepare(scenario)
    stage = pipeline.estimator
    if not reanchor:
        stage.observer.hold_total_momentum = lambda modelled, measured: None
    inertia, period, C = stage.inertia, scenario.sim.control_period_s, stage.observer.C
    w = np.array([0.02, -0.03, 1.0]) * DEG
    H = np.array([20.0, -15.0, -60.0]) - inertia * w
    stage.observer.z = w - [0.0, 0.0, stage.observer.spin_rate]
    command, errors = {}, []
    for k in range(round(duration / period)):
        t = k * period
        estimate = stage.estimate(t, {"y": np.array([C @ w])}, command)
        errors.append(np.linalg.norm(estimate["omega_estimate"] - w))
        command = {"torque_delivered": np.zeros(3), "momentum": H.copy(), "held_momentum": H.copy()}
        rate = -np.cross(estimate["omega"], H) if "omega" in estimate else np.zeros(3)
        rate = rate + (exchange_rate if t >= 100.0 else 0.0)
        if k == round(40.0 / period):
            H, w = H + jump, w - jump / inertia

        def f(s):
            return np.concatenate([(-np.cross(s[:3], inertia * s[:3] + s[3:]) - rate) / inertia, rate])
        s, h = np.concatenate([w, H]), period / 2  # RK4 at 0.025 s on rates of 1 deg/s: error ~1e-14
        for _ in range(2):
            k1 = f(s)
            k2 = f(s + h / 2 * k1)
            k3 = f(s + h / 2 * k2)
            s = s + h / 6 * (k1 + 2 * k2 + 2 * k3 + f(s + h * k3))
        w, H = s[:3], s[3:]
    return np.array(errors), period


@pytest.mark.slow
def test_momentum_exchange_the_command_does_not_contain_stays_algebraic():
    """An exchange of momentum between bus and cluster that the held command does not contain (a
    servo lag, a vertex switch, H(beta)'s curvature over the period) is measured at the next
    sample. Keeping L_b = I w_hat + H there (the estimate moves by -I^-1 dH) leaves an error of
    at most |I^-1 dH| for one period, then less than a tenth of it, decaying; without it the step
    is an integrated torque error that the high-gain observer turns into an excursion several
    times the step, and a steady exchange into a steady error. Measured: step |I^-1 dH| =
    4.3e-4 deg/s -> 3.3e-5 after one period (before: an excursion to 2.9e-3 at t = 46 s); a
    steady 7.3e-3 N m -> 2.4e-6 deg/s (before: 6.0e-4 to 7.5e-4)."""
    jump, exchange = np.array([0.0, 0.05, 0.02]), np.array([0.0, 0.002, 0.007])
    after, period = _estimate_under_exchange(jump, exchange, reanchor=True)
    before, _ = _estimate_under_exchange(jump, exchange, reanchor=False)
    step = np.linalg.norm(jump / np.array([1250.0, 6900.0, 7100.0]))    # |I^-1 dH|, locked inertia
    k_step, k_steady = round(40.0 / period), round(140.0 / period)
    assert after.max() <= 1.05 * step                          # one period at most the step itself
    assert after[k_step + 2:].max() < 0.1 * step               # then a tenth of it, decaying
    assert before[k_step + 2:k_step + 1200].max() > 3 * step   # the excursion: several steps
    assert before[k_steady:].min() > 100 * after[k_steady:].max()   # and a steady exchange stays


def test_idle_polar_angles_of_no_start_up_is_where_L_starts():
    """With no idle start-up (duration 0) the only angle is that of L(0) = I w(0) + H to body z."""
    inertia, held, omega0 = np.array([1250.0, 6900.0, 7100.0]), np.array([20.0, -35.0, 40.0]), np.array([0.01, -0.02, 0.005])
    L = inertia * omega0 + held
    np.testing.assert_allclose(idle_polar_angles(inertia, held, omega0, 0.0),
                               [np.degrees(np.arccos(L[2] / np.linalg.norm(L)))], rtol=1e-14)
