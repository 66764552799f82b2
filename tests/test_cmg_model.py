"""The CMG rhombus model (SEEDS §004) and the rigid satellite, checked against closed forms,
conservation laws and MuJoCo's own momentum bookkeeping."""

import mujoco
import numpy as np
import pytest

from testbed.errors import InputError
from testbed.systems.free_bus import FreeBus
from testbed.plugins import discover
from testbed.systems import cmg_rhombus, satellite
from testbed.systems.cmg_cluster.cluster import ClusterGeometry
from testbed.systems.cmg_cluster.plant import CmgRhombus
from testbed.systems.cmg_rhombus import CmgRhombusParams
from testbed.systems.cmg_cluster.arrays import rhombus_axes
from testbed.systems.cmg_rhombus.model import GIMBALS, ROTORS
from testbed.systems.registry import load_params

DT = 1e-3


def load_scenario_with(overrides: dict):
    from testbed.scenario.loading import load_scenario

    return load_scenario("cmg_open_loop", [f"{k}={v}" for k, v in overrides.items()])

ZERO_MOMENTUM_SET = np.radians([45.0, -45.0, -45.0, 45.0])


def seeds_momentum(h, alpha, beta):
    """SEEDS §004 eq. (15), typed from the paper."""
    c, s = np.cos(beta), np.sin(beta)
    return h * np.array([
        np.cos(alpha) * (c[0] - c[1] - c[2] + c[3]),
        np.sin(alpha) * (c[0] + c[1] - c[2] - c[3]),
        s[0] + s[1] - s[2] - s[3]])


def seeds_jacobian(h, alpha, beta):
    """dH/dbeta of eq. (15), differentiated by hand (SEEDS §004 eq. (18))."""
    c, s = np.cos(beta), np.sin(beta)
    ca, sa = np.cos(alpha), np.sin(alpha)
    return h * np.array([
        [-ca * s[0], ca * s[1], ca * s[2], -ca * s[3]],
        [-sa * s[0], -sa * s[1], sa * s[2], sa * s[3]],
        [c[0], c[1], -c[2], -c[3]]])


@pytest.mark.parametrize("alpha_deg", [30.0, 54.7356, 60.0])
def test_geometry_from_model_equals_seeds_eq15_and_eq18(alpha_deg):
    alpha = np.radians(alpha_deg)
    model = cmg_rhombus.build(CmgRhombusParams(alpha_deg=alpha_deg, rotor_momentum_nms=37.0), DT)
    geometry = ClusterGeometry.from_model(model)
    assert geometry.h == pytest.approx(37.0, rel=1e-12)
    assert geometry.alpha == pytest.approx(alpha, abs=1e-12)
    rng = np.random.default_rng(int(alpha_deg * 1000))
    for beta in rng.uniform(-np.pi, np.pi, size=(5, 4)):
        np.testing.assert_allclose(geometry.momentum(beta), seeds_momentum(37.0, alpha, beta),
                                   rtol=0, atol=37.0 * 1e-12)
        np.testing.assert_allclose(geometry.jacobian(beta), seeds_jacobian(37.0, alpha, beta),
                                   rtol=0, atol=37.0 * 1e-12)
        np.testing.assert_allclose(geometry.unit_jacobian(beta),
                                   seeds_jacobian(1.0, alpha, beta), rtol=0, atol=1e-12)


def test_singular_and_zero_momentum_gimbal_sets():
    alpha = np.radians(54.7356)
    geometry = ClusterGeometry.from_model(cmg_rhombus.build(CmgRhombusParams(alpha_deg=np.degrees(alpha)), DT))
    singular_values = np.linalg.svd(geometry.unit_jacobian(np.zeros(4)), compute_uv=False)
    assert np.sum(singular_values > 1e-12) == 1  # beta = 0: every column is along +-z
    assert geometry.singularity_measure(np.zeros(4)) < 1e-12
    np.testing.assert_allclose(geometry.momentum(ZERO_MOMENTUM_SET), 0.0, atol=1e-12)
    # J J^T = e1 e1^T + e2 e2^T + 2 z z^T there, so sqrt(det) = sqrt(2) sin(2 alpha)
    assert geometry.singularity_measure(ZERO_MOMENTUM_SET) == pytest.approx(
        np.sqrt(2.0) * np.sin(2.0 * alpha), rel=1e-12)


def test_compiled_gimbal_axes_lie_in_bus_plane_along_rhombus_sides():
    model = cmg_rhombus.build(CmgRhombusParams(alpha_deg=30.0), DT)
    data = mujoco.MjData(model)
    cmg = CmgRhombus(model)
    tilt = np.array([np.cos(0.4), np.sin(0.4), 0.0, 0.0])  # bus rolled 0.8 rad about x
    cmg.initialise(data, np.zeros(3), tilt, beta0=[0.3, -1.1, 2.0, 0.7])
    bus_rot = data.xmat[cmg.bus_body_id].reshape(3, 3)
    gimbal_axes_body = np.array([bus_rot.T @ data.xaxis[model.joint(n).id]
                                 for n in GIMBALS])
    np.testing.assert_allclose(gimbal_axes_body[:, 2], 0.0, atol=1e-14)
    np.testing.assert_allclose(np.cross(gimbal_axes_body[0], gimbal_axes_body[2]), 0, atol=1e-14)
    np.testing.assert_allclose(np.cross(gimbal_axes_body[1], gimbal_axes_body[3]), 0, atol=1e-14)
    # spin axes from MuJoCo's kinematics equal the geometry's cos b e + sin b s z
    spin_axes_body = np.array([bus_rot.T @ data.xaxis[model.joint(n).id]
                               for n in ROTORS])
    np.testing.assert_allclose(spin_axes_body, cmg.geometry.spin_axes(cmg.gimbal_angles(data)),
                               atol=1e-14)


def analytic_system_inertia(p, beta):
    """Bus + CMGs at d e_i (parallel axis: sum_i m d^2 (1 - e_i e_i^T) = 4 m d^2
    diag(sin^2 a, cos^2 a, 1)) + each gimbal's and rotor's inertia turned by beta_i."""
    alpha = np.radians(p.alpha_deg)
    e, g, sz = rhombus_axes(alpha)
    js = p.rotor_momentum_nms / (p.rotor_speed_rpm * np.pi / 30.0)
    jt = p.rotor_transverse_ratio * js
    mass = p.gimbal_mass_kg + p.rotor_mass_kg
    s2, c2 = np.sin(alpha) ** 2, np.cos(alpha) ** 2
    total = np.diag(p.inertia_kg_m2) + 4 * mass * p.cmg_distance_m**2 * np.diag([s2, c2, 1.0])
    for i, b in enumerate(beta):
        spin = np.cos(b) * e[i] + np.sin(b) * sz[i]
        third = np.cos(b) * sz[i] - np.sin(b) * e[i]
        ig = p.gimbal_inertia_kg_m2
        total += ig[0] * np.outer(g[i], g[i]) + ig[1] * np.outer(spin, spin) \
            + ig[2] * np.outer(third, third)
        total += jt * np.eye(3) + (js - jt) * np.outer(spin, spin)
    return total


def test_system_com_at_origin_and_inertia_matches_analytic():
    params = CmgRhombusParams(inertia_kg_m2=[700.0, 900.0, 1300.0], rotor_transverse_ratio=0.55)
    model = cmg_rhombus.build(params, DT)
    data = mujoco.MjData(model)
    cmg = CmgRhombus(model)
    beta = np.array([0.2, 1.3, -0.7, 2.9])
    cmg.initialise(data, [0.01, 0.02, -0.03], [0.9, 0.1, -0.3, 0.2], beta0=beta)
    np.testing.assert_allclose(cmg.com_offset_body(data), 0.0, atol=1e-14)
    np.testing.assert_allclose(cmg.system_inertia(data), analytic_system_inertia(params, beta),
                               rtol=1e-12, atol=1e-9)


def test_internal_momentum_at_rest_equals_cluster_momentum():
    model = cmg_rhombus.build(CmgRhombusParams(), DT)
    data = mujoco.MjData(model)
    cmg = CmgRhombus(model)
    beta = np.array([0.4, -0.9, 1.7, 0.1])
    speeds = np.array([620.0, 630.0, 625.0, 640.0])
    quat = np.array([0.8, -0.2, 0.5, 0.1]) / np.linalg.norm([0.8, -0.2, 0.5, 0.1])
    cmg.initialise(data, np.zeros(3), quat, beta0=beta, rotor_speed=speeds)
    expected = cmg.geometry.momentum(beta, rotor_rates=speeds)
    bus_rot = data.xmat[cmg.bus_body_id].reshape(3, 3)
    # MuJoCo's own total momentum: with the bus still, all of it is the cluster's
    from_subtree = bus_rot.T @ cmg.total_angular_momentum_world(data)
    scale = np.linalg.norm(expected)
    np.testing.assert_allclose(from_subtree, expected, rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(cmg.internal_momentum_body(data), expected, rtol=0,
                               atol=1e-9 * scale)


def run_sinusoidal_gimbals(dt, duration, amplitude, frequency_hz, omega0):
    """Simulate with gimbal-rate commands amplitude sin(2 pi f t); return times, commanded
    and measured gimbal rates, and the world momentum at start and end."""
    model = cmg_rhombus.build(CmgRhombusParams(), dt)
    data = mujoco.MjData(model)
    cmg = CmgRhombus(model)
    cmg.initialise(data, omega0, [1.0, 0.0, 0.0, 0.0])
    momentum_start = cmg.total_angular_momentum_world(data)
    steps = int(round(duration / dt))
    times, commands, rates = np.empty(steps), np.empty((steps, 4)), np.empty((steps, 4))
    for k in range(steps):
        command = amplitude * np.sin(2 * np.pi * frequency_hz * data.time)
        cmg.set_gimbal_rate_command(data, command)
        mujoco.mj_step(model, data)
        # qvel after the step belongs to data.time; compare with the command at that time
        times[k], rates[k] = data.time, cmg.gimbal_rates(data)
        commands[k] = amplitude * np.sin(2 * np.pi * frequency_hz * data.time)
    assert data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number == 0
    return times, commands, rates, momentum_start, cmg.total_angular_momentum_world(data)


@pytest.mark.parametrize("dt", [1e-3, 2e-3])
def test_gimbal_servo_tracks_rate_and_momentum_is_conserved(dt):
    amplitude = np.array([0.10, 0.08, 0.12, 0.06])
    # the servo damps the absolute gimbal rate, so a sinusoid of w rad/s lags by about
    # 2 zeta w / w_n of its amplitude: 0.6 % at 0.15 Hz with w_n = 316 rad/s
    frequency = np.array([0.10, 0.15, 0.12, 0.08])
    times, commands, rates, l_start, l_end = run_sinusoidal_gimbals(
        dt, 5.0, amplitude, frequency, omega0=[0.01, -0.02, 0.015])
    settled = times > 0.1
    tracking_error = np.max(np.abs(rates[settled] - commands[settled]), axis=0) / amplitude
    assert np.all(tracking_error < 0.01)
    # no external torque: the world-frame momentum about the CoM is constant
    assert np.linalg.norm(l_end - l_start) <= 1e-9 * np.linalg.norm(l_start)


def test_servo_gains_scale_with_gimbal_axis_inertia():
    for gimbal_inertia in [(0.03, 0.02, 0.02), (0.3, 0.2, 0.2)]:
        params = CmgRhombusParams(gimbal_inertia_kg_m2=list(gimbal_inertia), servo_natural_frequency_rad_s=250.0,
                                  servo_damping_ratio=0.8)
        model = cmg_rhombus.build(params, DT)
        # inertia about the gimbal axis as MuJoCo sees it: the mass-matrix diagonal entry
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        mass_matrix = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, mass_matrix)
        actuator = model.actuator("gimbal_rate1")
        dof = model.joint("gimbal1").dofadr[0]
        inertia = mass_matrix[dof, dof]
        kp, kv = actuator.gainprm[0], -actuator.biasprm[2]
        assert np.sqrt(kp / inertia) == pytest.approx(250.0, rel=1e-12)
        assert kv / (2.0 * np.sqrt(kp * inertia)) == pytest.approx(0.8, rel=1e-12)


@pytest.mark.parametrize("field, value", [
    ("alpha_deg", 97.4), ("rotor_momentum_nms", -1.0), ("inertia_kg_m2", [100.0, 100.0, 300.0]),
    ("gimbal_angles_deg", [0.0, 1.0]), ("rotor_transverse_ratio", 0.3),
    ("gimbal_inertia_kg_m2", [0.05, 0.01, 0.03]), ("servo_model", "pid"), ("gimbal_torque_limit_nm", 0.0),
    ("gimbal_rate_limit_deg_s", -5.0)])
def test_bad_parameters_raise_input_error(field, value):
    discover()
    with pytest.raises(InputError) as error:
        load_params({"system": "cmg_rhombus", field: value}, "model")
    assert error.value.field == f"model.{field}"


@pytest.mark.parametrize("field, dt, value", [
    ("servo_natural_frequency_rad_s", 1e-3, 2000.0), ("rotor_speed_time_constant_s", 0.002, 0.003)])
def test_parameters_too_fast_for_the_step_are_refused_at_build(field, dt, value):
    """RK4 bounds: w_n dt <= 0.7 for the gimbal servo, dt / tau <= 0.5 for the rotor loop."""
    with pytest.raises(InputError) as error:
        cmg_rhombus.build(CmgRhombusParams(**{field: value}), dt)
    assert error.value.field == f"model.{field}"


def test_unknown_integrator_is_refused():
    with pytest.raises(InputError) as error:
        load_scenario_with({"sim.integrator": "RK45"})
    assert error.value.field == "sim.integrator"


def test_satellite_constant_torque_from_rest_follows_euler():
    """About a principal axis from rest, I w' = M gives w = M t / I and angle M t^2 / (2 I)."""
    params = satellite.SatelliteParams(inertia_kg_m2=[300.0, 500.0, 600.0])
    model = satellite.build(params, 0.01)
    data = mujoco.MjData(model)
    sat = FreeBus(model)
    sat.set_free_joint_state(data, np.zeros(3), [1.0, 0.0, 0.0, 0.0])
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(sat.system_inertia(data), np.diag([300.0, 500.0, 600.0]),
                               rtol=1e-14)
    sat.set_body_torque(data, [0.0, 2.0, 0.0])
    mujoco.mj_step(model, data, nstep=1000)
    np.testing.assert_allclose(sat.body_omega(data), [0.0, 2.0 * 10.0 / 500.0, 0.0],
                               atol=1e-12)
    angle = 2.0 * 10.0**2 / (2 * 500.0)
    np.testing.assert_allclose(sat.body_quat(data),
                               [np.cos(angle / 2), 0.0, np.sin(angle / 2), 0.0], atol=1e-10)
    expected_momentum = sat.system_inertia(data) @ sat.body_omega(data)  # about y: world = body
    np.testing.assert_allclose(sat.total_angular_momentum_world(data), expected_momentum,
                               atol=1e-10)


def test_readouts_after_step_describe_the_new_state_and_leave_trajectory_unchanged():
    """After mj_step, data's kinematics belong to the step's start; the read-outs refresh
    them. Checked against mj_forward on a copy of the new state, and by bit-identical runs."""
    model = cmg_rhombus.build(CmgRhombusParams(), DT)
    cmg = CmgRhombus(model)

    def run(read_every_step):
        data = mujoco.MjData(model)
        cmg.initialise(data, [0.01, 0.02, 0.03], [1.0, 0.0, 0.0, 0.0])
        for k in range(200):
            cmg.set_gimbal_rate_command(data, [0.3 * np.sin(0.01 * k), 0.2, -0.1, 0.4])
            mujoco.mj_step(model, data)
            if read_every_step:
                cmg.total_angular_momentum_world(data)
                cmg.internal_momentum_body(data)
        return data

    stepped, quiet = run(True), run(False)
    assert np.array_equal(stepped.qpos, quiet.qpos) and np.array_equal(stepped.qvel, quiet.qvel)
    mujoco.mj_step(model, quiet)
    fresh = mujoco.MjData(model)
    fresh.qpos[:], fresh.qvel[:] = quiet.qpos, quiet.qvel
    mujoco.mj_forward(model, fresh)
    got = (cmg.system_inertia(quiet), cmg.internal_momentum_body(quiet),
           cmg.total_angular_momentum_world(quiet))
    expected = (cmg.system_inertia(fresh), cmg.internal_momentum_body(fresh),
                cmg.total_angular_momentum_world(fresh))
    for value, reference in zip(got, expected):
        np.testing.assert_allclose(value, reference, rtol=0, atol=1e-13 * np.abs(reference).max())


@pytest.mark.parametrize("omega_deg_s", [[0.25, -0.25, 0.0], [0.5, -0.5, 0.5], [-0.31, 0.12, 0.44]])
def test_cancel_initial_momentum_starts_a_zero_momentum_spacecraft(omega_deg_s):
    """With cancel_initial_momentum the total angular momentum (MuJoCo's subtree_angmom) is zero at
    t = 0 for any initial rate, the servos start on the moved angles, and for the flagship's rate
    the angles are the flagship's own, computed for it by hand from H(b) = -I w(0) with the
    locked inertia (1250, 6900, 7100) kg m^2 (scenarios/lebedev_spinup_cmg.yaml)."""
    from testbed.runner import prepare
    from testbed.scenario.loading import load_scenario

    scenario = load_scenario("lebedev_spinup_cmg", ["model.cancel_initial_momentum=true",
                                                    f"initial.omega_deg_s={omega_deg_s}"])
    plant, _, _ = prepare(scenario)
    scale = 4 * 75.0
    assert np.linalg.norm(plant.angular_momentum_world()) <= 1e-12 * scale
    beta = plant.bus.gimbal_angles(plant.data)
    assert np.array_equal(plant.data.act[plant.bus.gimbal_act_adr], beta)
    assert np.allclose(np.degrees(plant.omega()), omega_deg_s, rtol=0, atol=1e-12)
    if omega_deg_s == [0.25, -0.25, 0.0]:
        assert np.allclose(np.degrees(beta), [37.07935401, -32.93984234, -52.05111216, 57.96476249], atol=1e-5)


def test_cancel_initial_momentum_beyond_the_envelope_is_refused():
    """|I w| = 7100 kg m^2 x 5 deg/s = 620 N m s along z: more than the 4 h = 300 N m s the cluster holds."""
    from testbed.runner import prepare
    from testbed.scenario.loading import load_scenario

    scenario = load_scenario("lebedev_spinup_cmg", ["model.cancel_initial_momentum=true", "initial.omega_deg_s=[0, 0, 5]"])
    with pytest.raises(InputError) as err:
        prepare(scenario)
    assert err.value.field == "model.cancel_initial_momentum"


@pytest.mark.parametrize("params", [CmgRhombusParams(), CmgRhombusParams(
    alpha_deg=40.0, rotor_transverse_ratio=0.8, gimbal_inertia_kg_m2=[0.12, 0.05, 0.09], rotor_momentum_nms=20.0)])
def test_held_momentum_is_mujocos_internal_momentum(params):
    """What the allocator reports as the momentum the cluster holds in full (rotor spin plus the
    gimbal frames and rotors turning with the tachometers' gimbal rates, J_g,i from the compiled
    model) equals the bus row of MuJoCo's mass matrix times the joint rates, at random angles,
    gimbal rates and rotor speeds; and differs from the spin momentum by J_g b' (not zero)."""
    model = cmg_rhombus.build(params, DT)
    data = mujoco.MjData(model)
    cmg = CmgRhombus(model)
    rng = np.random.default_rng(16)
    for _ in range(5):
        beta, rates, rotor = rng.uniform(-np.pi, np.pi, 4), rng.uniform(-0.2, 0.2, 4), rng.uniform(300, 700, 4)
        cmg.initialise(data, rng.normal(size=3) * 0.01, np.array([1.0, 0, 0, 0]), beta0=beta, rotor_speed=rotor)
        data.qvel[cmg.gimbal_qvel_adr] = rates
        mujoco.mj_forward(model, data)
        truth = cmg.internal_momentum_body(data)
        held = cmg.geometry.held_momentum(beta, rotor, rates)
        np.testing.assert_allclose(held, truth, rtol=0, atol=1e-12 * np.abs(truth).max())
        assert np.linalg.norm(held - cmg.geometry.momentum(beta, rotor)) > 1e-3
