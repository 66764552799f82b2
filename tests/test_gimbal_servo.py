"""The feedforward gimbal servo (testbed/systems/cmg_cluster/gimbal_servo.py) on cases that are
not shipped scenarios: tracking of the held command, conservation of the total angular
momentum, its deadbeat gains against a numerical solution, its limits and its observer."""

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from testbed.errors import InputError
from testbed.systems.cmg_cluster.plant import CmgPlant
from testbed.systems.cmg_rhombus import CmgRhombusParams, build
from testbed.systems.cmg_cluster.gimbal_servo import kernel_moments, rate_deadbeat_gains


@pytest.mark.parametrize("w_n, zeta, tc", [(5.0, 1.0, 0.01), (30.0, 0.7, 0.02), (60.0, 1.3, 0.05)])
def test_deadbeat_gains_end_the_tick_at_zero_rate_error(w_n, zeta, tc):
    """theta' = e, e' = -w_n^2 theta - 2 zeta w_n e + a with a = -(p theta0 + q e0): solve_ivp
    ends the period at e = 0 from any start; and Gamma_1 is e(Tc) for a = 1 from rest."""
    p, q, gamma = rate_deadbeat_gains(w_n, zeta, tc)

    def end_state(theta0, e0, a):
        sol = solve_ivp(lambda t, x: [x[1], -w_n**2 * x[0] - 2 * zeta * w_n * x[1] + a], (0, tc), [theta0, e0],
                        method="DOP853", rtol=1e-12, atol=1e-15)
        return sol.y[:, -1]

    assert end_state(0.0, 0.0, 1.0)[1] == pytest.approx(gamma, rel=1e-9)
    rng = np.random.default_rng(7)
    for theta0, e0 in rng.normal(size=(4, 2)) * [1e-3, 1e-2]:
        assert abs(end_state(theta0, e0, -(p * theta0 + q * e0))[1]) < 1e-10 * (abs(e0) + w_n * abs(theta0))


@pytest.mark.parametrize("w_n, tc", [(5.0, 0.05), (1.0, 0.01), (30.0, 0.02)])
def test_kernel_moments_against_the_critically_damped_response(w_n, tc):
    """At zeta = 1 the rate's response to a unit acceleration impulse is G(tau) = e^(-w tau) (1 - w tau)
    (a closed form); m_k = int G(Tc - s) s^k ds / int G by quadrature (well conditioned: 1e-10)."""
    from scipy.integrate import quad
    response = lambda s: np.exp(-w_n * (tc - s)) * (1.0 - w_n * (tc - s))
    gamma = quad(response, 0.0, tc, epsabs=0, epsrel=1e-13)[0]
    m1, m2 = kernel_moments(w_n, 1.0, tc)
    assert m1 == pytest.approx(quad(lambda s: response(s) * s, 0.0, tc, epsabs=0, epsrel=1e-13)[0] / gamma, rel=1e-10)
    assert m2 == pytest.approx(quad(lambda s: response(s) * s * s, 0.0, tc, epsabs=0, epsrel=1e-13)[0] / gamma, rel=1e-10)


def drive(params: CmgRhombusParams, dt, tc, duration, amplitude, frequency_hz, phase=0.0,
          omega0=(0.004, -0.002, 0.003), damping=0.0, settle=0.1, command=None, refined=None, plants=None):
    """Run the plant (as the runner does: command held for tc) with sinusoidal gimbal-rate
    commands (or command(t)); return the largest |b'(t_k+1) - c(t_k)| / amplitude after `settle` s,
    the largest |L(t) - L(0)| / stored rotor momentum, and the largest gimbal motor torque.
    `refined`: the jump refinement's factor in place of its default; `plants`: a list the
    plant is appended to."""
    plant = CmgPlant(build(params, dt), params, tc)
    if refined is not None:
        plant.jumps.factor = refined
    if plants is not None:
        plants.append(plant)
    plant.model.dof_damping[plant.bus.gimbal_qvel_adr] = damping  # a torque the servo does not model
    plant.initialise(SimpleNamespace(omega=np.asarray(omega0, float), quat=np.array([1.0, 0, 0, 0])))
    momentum0, scale = plant.angular_momentum_world(), plant.momentum_scale()
    tracking = drift = torque = 0.0
    held = None
    for k in range(round(duration / tc)):
        t = k * tc
        if held is not None and t > settle:
            tracking = max(tracking, np.max(np.abs(plant.bus.gimbal_rates(plant.data) - held) / amplitude))
        held = amplitude * np.sin(2 * np.pi * frequency_hz * t + phase) if command is None else command(t)
        plant.apply({"gimbal_rates": held})
        plant.step(round(tc / dt))
        drift = max(drift, np.linalg.norm(plant.angular_momentum_world() - momentum0) / scale)
        torque = max(torque, np.max(np.abs(plant.data.qfrc_actuator[plant.bus.gimbal_qvel_adr])))
    return tracking, drift, torque


# (gimbal inertia, h, amplitude rad/s, frequency Hz, dt, Tc): other inertias, momenta,
# amplitudes and frequencies than any scenario, at three steps
CASES = [
    ((0.1, 0.06, 0.05), 37.0, [0.05, 0.08, 0.03, 0.06], [0.03, 0.05, 0.021, 0.07], 0.005, 0.01),
    ((0.02, 0.015, 0.012), 60.0, [0.02, 0.04, 0.05, 0.01], [0.1, 0.017, 0.04, 0.06], 0.01, 0.01),
    ((0.05, 0.03, 0.03), 25.0, [0.1, 0.1, 0.1, 0.1], [0.011, 0.013, 0.017, 0.019], 0.02, 0.02),
]


def case_params(gimbal_inertia, h, dt, **servo):
    return CmgRhombusParams(gimbal_inertia_kg_m2=list(gimbal_inertia), rotor_momentum_nms=h,
                            rotor_speed_time_constant_s=max(0.02, 2 * dt), gimbal_angles_deg=[20, -50, 10, 80], **servo)


@pytest.mark.parametrize("gimbal_inertia, h, amplitude, frequency, dt, tc", CASES)
def test_feedforward_tracks_the_held_command_and_conserves_momentum(gimbal_inertia, h, amplitude, frequency, dt, tc):
    amplitude, frequency, phase = np.array(amplitude), np.array(frequency), np.array([0.3, 1.1, 2.0, 4.0])
    feedforward = {"servo_model": "feedforward", "servo_natural_frequency_rad_s": 5.0}
    # the start's jump from rest to the first command is not stepped finer here (refined=1): the
    # drift below is RK4's on the smooth commands, whose order is what this test measures
    tracking, drift, _ = drive(case_params(gimbal_inertia, h, dt, **feedforward), dt, tc, 30.0, amplitude, frequency,
                               phase, refined=1)
    # measured 9e-6, 4.9e-5 and 4.3e-5 of the amplitude, whatever dt; the bound is 2e-3
    assert tracking < 5e-4
    stiff = {"servo_natural_frequency_rad_s": 0.69 / dt}  # the stiffest intvelocity servo RK4 accepts
    stiff_tracking, _, _ = drive(case_params(gimbal_inertia, h, dt, **stiff), dt, tc, 30.0, amplitude, frequency, phase)
    assert tracking < stiff_tracking / 30  # measured 500 to 2000 times less

    # no torque acts from outside: what drifts is RK4's truncation error, fourth order in dt
    # (measured 2.2e-11, 1.4e-10, 6.8e-9 of the stored momentum; 16 to 17 times less at dt / 2)
    _, finer_drift, _ = drive(case_params(gimbal_inertia, h, dt / 2, **feedforward), dt / 2, tc, 30.0, amplitude,
                              frequency, phase, refined=1)
    assert finer_drift < drift / 8
    assert finer_drift < 1e-9 and (dt > 0.01 or drift < 1e-9)


@pytest.mark.parametrize("h, inertia, dt, tc", [(75.0, [1250.0, 6900.0, 7100.0], 0.01, 0.05),
                                                (30.0, [300.0, 450.0, 500.0], 0.005, 0.02)])
def test_feedforward_follows_command_jumps_within_the_tick(h, inertia, dt, tc):
    """Rates that jump between random levels (up to 10 deg/s, every 2 to 5 ticks) on a spinning
    bus, like min-max commands at the rate limit: the rate ends every tick near the command it
    held, the ticks right after each jump too. Linear extrapolation of the observed disturbance
    alone missed by 8.5 % and 3.0 % of the amplitude (the gyroscopic torque changes slope with the
    rates); with the angle term (FeedForwardServo.angle_sensitivity_times) 0.66 % and 0.38 %. The band
    is physical (a servo good to 1.5 % of its rate limit), far from round-off."""
    rng = np.random.default_rng(11)
    amplitude = np.radians(10.0)
    times = np.cumsum(rng.integers(2, 6, size=200)) * tc
    levels = rng.uniform(-amplitude, amplitude, size=(201, 4))

    def command(t):
        return levels[np.searchsorted(times, t + 1e-9 * tc, side="right")]

    params = CmgRhombusParams(inertia_kg_m2=inertia, rotor_momentum_nms=h, servo_model="feedforward",
                              servo_natural_frequency_rad_s=5.0, gimbal_angles_deg=[20, -50, 10, 80],
                              rotor_speed_time_constant_s=max(0.02, 2 * dt))
    tracking, _, _ = drive(params, dt, tc, 20.0, amplitude, None, omega0=(0.02, -0.03, 0.01),
                           settle=0.0, command=command)
    assert tracking < 1.5e-2


def test_the_ticks_after_command_jumps_are_stepped_finer_and_conserve_momentum():
    """Rates that jump as above, on the flagship's bus at dt 0.01 s with the soft PD: RK4's drift
    is made in the ticks after the jumps. Those ticks at dt / 4 (jump_refinement.py) drift
    2.1e-11 against 8.7e-10 unrefined, and 3.0e-12 with every tick at dt / 4 (a second method,
    four times the cost): 42 times less, within 7 of the all-fine run. Each jump over 1 deg/s (no
    rate limit set) is refined once, the step is given back, and the clock is the ticks'."""
    rng = np.random.default_rng(11)
    amplitude, tc, dt, duration = np.radians(10.0), 0.05, 0.01, 20.0
    times = np.cumsum(rng.integers(2, 6, size=200)) * tc
    levels = rng.uniform(-amplitude, amplitude, size=(201, 4))

    def command(t):
        return levels[np.searchsorted(times, t + 1e-9 * tc, side="right")]

    params = CmgRhombusParams(inertia_kg_m2=[1250.0, 6900.0, 7100.0], rotor_momentum_nms=75.0,
                              servo_model="feedforward", servo_natural_frequency_rad_s=0.1,
                              gimbal_angles_deg=[20, -50, 10, 80])
    plants = []
    run = dict(omega0=(0.02, -0.03, 0.01), settle=0.0, command=command)
    _, drift, _ = drive(params, dt, tc, duration, amplitude, None, plants=plants, **run)
    _, unrefined, _ = drive(params, dt, tc, duration, amplitude, None, refined=1, **run)
    _, all_fine, _ = drive(params, dt / 4, tc, duration, amplitude, None, refined=1, **run)
    assert drift < unrefined / 10 and drift < 10 * all_fine
    ticks = round(duration / tc)
    held = np.array([command(k * tc) for k in range(ticks)])
    jumps = int(np.sum(np.max(np.abs(np.diff(held, axis=0)), axis=1) > np.radians(1.0)))
    jumps += bool(np.max(np.abs(held[0])) > np.radians(1.0))  # from rest to the first command
    plant = plants[0]
    assert plant.jumps.refined_calls == jumps  # one call a tick here
    assert plant.model.opt.timestep == dt
    assert plant.data.time == pytest.approx(duration, rel=1e-12)  # well conditioned: a sum of 2000 steps


def test_angle_sensitivity_times_is_the_assembled_matrix_times_the_vector():
    """D x without D (the factored product) against D assembled from its definition,
    D_ij = -h_i h_j J_i^T R J_j - [i = j] h_i w . s_i, with J and s from the cluster written out
    independently (rhombus_reference.py) and R the inverse of the bus's mass block read here:
    two orders of the same sums, so equal to round-off (1e-13 of |D| |x|), at random gimbal
    angles, rotor speeds and bus rates on a bus that is not the shipped ones."""
    import mujoco
    from tests.rhombus_reference import rhombus_column_derivative, rhombus_jacobian
    rng = np.random.default_rng(5)
    params = CmgRhombusParams(inertia_kg_m2=[410.0, 530.0, 380.0], rotor_momentum_nms=40.0,
                              alpha_deg=48.0, servo_model="feedforward", servo_natural_frequency_rad_s=5.0)
    plant = CmgPlant(build(params, 0.01), params, 0.01)
    for _ in range(3):
        beta = rng.uniform(-np.pi, np.pi, 4)
        plant.initialise(SimpleNamespace(omega=rng.normal(scale=0.05, size=3), quat=np.array([1.0, 0, 0, 0])))
        plant.data.qpos[plant.bus.gimbal_qpos] = beta
        plant.data.qvel[plant.bus.rotor_qvel] *= rng.uniform(0.5, 1.5, 4)
        mujoco.mj_forward(plant.model, plant.data)
        full = np.zeros((plant.model.nv, plant.model.nv))
        mujoco.mj_fullM(plant.model, plant.data, full)
        bus = np.arange(plant.bus.qvel_adr, plant.bus.qvel_adr + 6)
        response = np.linalg.inv(full[np.ix_(bus, bus)])[3:, 3:]
        plant.servo._bus_response = response.tolist()  # R at these angles, as start() reads it at t = 0
        h = plant.bus.geometry.spin_inertia * plant.data.qvel[plant.bus.rotor_qvel]
        omega = plant.data.qvel[plant.bus.qvel_adr + 3:plant.bus.qvel_adr + 6]
        jacobian = rhombus_jacobian(beta, np.radians(48.0))
        spin = -rhombus_column_derivative(beta, np.radians(48.0))
        matrix = -np.outer(h, h) * (jacobian.T @ response @ jacobian) - np.diag(h * (omega @ spin))
        x = rng.normal(scale=1e-3, size=4)
        got = np.array(plant.servo.angle_sensitivity_times(x.tolist()))
        np.testing.assert_allclose(got, matrix @ x, rtol=0, atol=1e-13 * np.abs(matrix).max() * np.abs(x).max())


def test_observer_learns_a_torque_it_does_not_model():
    """Viscous friction in the gimbal bearings (0.3 N m s/rad): tracking as without it."""
    params = CmgRhombusParams(servo_model="feedforward", servo_natural_frequency_rad_s=5.0)
    amplitude, frequency = np.full(4, 0.05), np.array([0.02, 0.03, 0.05, 0.04])
    plain, _, _ = drive(params, 0.01, 0.01, 20.0, amplitude, frequency)
    rubbing, drift, _ = drive(params, 0.01, 0.01, 20.0, amplitude, frequency, damping=0.3)
    assert rubbing < 2 * plain + 1e-5 and rubbing < 1e-4
    assert drift < 1e-9  # friction acts between gimbal and bus: momentum is still conserved


def test_torque_limit_is_never_exceeded_and_momentum_is_kept():
    """A command that starts at 0.1 rad/s needs 1.2 N m for the first tick; with 0.8 N m the
    motor saturates for three ticks, then tracks as without a limit."""
    amplitude, frequency = np.full(4, 0.1), np.full(4, 0.05)
    free = CmgRhombusParams(servo_model="feedforward", servo_natural_frequency_rad_s=5.0)
    free_tracking, _, free_torque = drive(free, 0.005, 0.01, 1.5, amplitude, frequency, phase=np.pi / 2,
                                          omega0=(0.01, 0.0, -0.005), settle=0.2)
    limited = CmgRhombusParams(servo_model="feedforward", servo_natural_frequency_rad_s=5.0, gimbal_torque_limit_nm=0.8)
    tracking, drift, torque = drive(limited, 0.005, 0.01, 1.5, amplitude, frequency, phase=np.pi / 2,
                                    omega0=(0.01, 0.0, -0.005), settle=0.2)
    assert free_torque > 1.0 and torque <= 0.8 + 1e-12  # the limit did bite, and held
    assert tracking < 1e-3 and free_tracking < 1e-4
    assert drift < 1e-10  # the limit acts between gimbal and bus: momentum is kept


def test_rate_limit_clips_the_command():
    params = CmgRhombusParams(servo_model="feedforward", servo_natural_frequency_rad_s=5.0, gimbal_rate_limit_deg_s=2.0)
    plant = CmgPlant(build(params, 0.01), params, 0.01)
    plant.initialise(SimpleNamespace(omega=np.zeros(3), quat=np.array([1.0, 0, 0, 0])))
    command = np.radians([5.0, -5.0, 1.0, -1.0])
    for _ in range(50):
        plant.apply({"gimbal_rates": command})
        plant.step(1)
    np.testing.assert_allclose(plant.bus.gimbal_rates(plant.data), np.radians([2.0, -2.0, 1.0, -1.0]), atol=1e-6)
    # what the servo was asked (its command before the limit) is what truth records
    np.testing.assert_array_equal(plant.truth()["gimbal_rate_command"], command)


def test_truth_records_the_command_held_until_the_sample():
    params = CmgRhombusParams(servo_model="feedforward", servo_natural_frequency_rad_s=5.0)
    plant = CmgPlant(build(params, 0.01), params, 0.01)
    plant.initialise(SimpleNamespace(omega=np.zeros(3), quat=np.array([1.0, 0, 0, 0])))
    first, second = np.array([0.01, 0.02, 0.03, 0.04]), np.array([0.05, 0.06, 0.07, 0.08])
    plant.apply({"gimbal_rates": first})
    np.testing.assert_array_equal(plant.truth()["gimbal_rate_command"], np.zeros(4))  # held before t = 0
    plant.step(1)
    plant.apply({"gimbal_rates": second})
    np.testing.assert_array_equal(plant.truth()["gimbal_rate_command"], first)
    plant.step(1)  # the end of a run: no new command at this time
    np.testing.assert_array_equal(plant.truth()["gimbal_rate_command"], second)


def test_a_servo_faster_than_the_tick_is_refused_for_feedforward():
    params = CmgRhombusParams(servo_model="feedforward", servo_natural_frequency_rad_s=300.0)
    with pytest.raises(InputError) as error:
        CmgPlant(build(params, 0.002), params, 0.05)
    assert error.value.field == "model.servo_natural_frequency_rad_s"


@pytest.mark.parametrize("window", [slice(3, 11), slice(0, 8, 2)])
def test_float_writer_writes_what_numpy_assignment_writes(window):
    """The servo's command goes into MuJoCo's ctrl through `float_writer` (packed bytes where the
    view is contiguous): the array afterwards equals one written by numpy's own assignment."""
    import mujoco

    from testbed.plant import float_writer

    model = build(CmgRhombusParams(servo_model="feedforward", servo_natural_frequency_rad_s=5.0), 0.01)
    data, expected = mujoco.MjData(model), mujoco.MjData(model)
    values = [0.1 * i - 0.3 for i in range(len(range(model.nu)[window]))]
    float_writer(data.ctrl[window])(*values)
    expected.ctrl[window] = values
    assert data.ctrl.tolist() == expected.ctrl.tolist() and data.ctrl[window].tolist() == values
