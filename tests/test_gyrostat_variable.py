"""Variable-structure gyrostat of seed 002 (models/gyrostat_variable.xml) and the paper's
z-x-z Euler angles (testbed/math/euler_angles.py), checked against hand numbers and MuJoCo."""

import mujoco
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from testbed.scenario import schema
from testbed.scenario.shipped_files import MODELS_DIR
from testbed.systems.gyrostat_variable import model as gv
from testbed.systems.gyrostat_variable.plant import VariableGyrostatPlant
from testbed.errors import InputError
from testbed.math.euler_angles import angle_rates, body_rates, euler_from_quat, quat_from_euler
from testbed.math.quaternion import quat_from_axis_angle, quat_mul, quat_rotate

PARAMS = gv.VariableGyrostatParams()

# Hand numbers (worked example): cylinder 495 kg R = h = 1 -> central (165, 165, 247.5);
# its centre d = m2 l2 / m_cyl = 150 / 495 m below O, so 495 d^2 = 150^2 / 495 = 45.4545...
# rod 5 kg, 0.5 m, centre at O: 5/48 about any transverse axis through O;
# rotor 300 kg: central (81.25, 54.25, 123), plus 300 * 0.5^2 = 75 on x2 and y2.
STEINER_1 = 150.0**2 / 495.0
ROD = 5.0 / 48.0


def _rotation(quat):
    """Rotation matrix of a unit quaternion (w, x, y, z), via quat_rotate on the basis."""
    return np.column_stack([quat_rotate(quat, e) for e in np.eye(3)])


def _inertia_from_model_fields(model, bodies, rod_angle):
    """Carrier-axes inertia about O from body_mass/ipos/iquat/inertia alone (no MuJoCo
    kinematics): the rod body is turned by rod_angle about carrier y, Huygens-Steiner."""
    total = np.zeros((3, 3))
    for name in bodies:
        b = model.body(name).id
        body_quat = model.body_quat[b]
        if name == "rod":
            body_quat = quat_mul(body_quat, quat_from_axis_angle([0.0, 1.0, 0.0], rod_angle))
        rot = _rotation(quat_mul(body_quat, model.body_iquat[b]))
        r = model.body_pos[b] + quat_rotate(body_quat, model.body_ipos[b])
        m = model.body_mass[b]
        total += rot @ np.diag(model.body_inertia[b]) @ rot.T + m * (r @ r * np.eye(3) - np.outer(r, r))
    return total


@pytest.fixture(scope="module")
def model():
    return gv.build(PARAMS)


def test_xml_defaults_are_the_built_defaults(model):
    raw = mujoco.MjModel.from_xml_path(str(MODELS_DIR / gv.XML_FILE))
    for field in ("body_mass", "body_inertia", "body_ipos", "body_pos", "actuator_gainprm", "actuator_biasprm"):
        np.testing.assert_allclose(getattr(raw, field), getattr(model, field), rtol=1e-12, atol=1e-12, err_msg=field)


def test_common_centre_of_mass_is_O(model):
    data = mujoco.MjData(model)
    for t in (0.0, 4.0, 11.0):
        data.qpos[model.joint("rod_hinge").qposadr[0]] = 0.1 * t
        data.qpos[model.joint("rotor_hinge").qposadr[0]] = t
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        np.testing.assert_allclose(data.subtree_com[model.body("bus").id], data.xpos[model.body("bus").id], atol=1e-15)
    # T1 = cylinder + rod: its centre of mass sits at l1 = 0.3 m from O (paper: 500 * 0.3 = 300 * 0.5).
    assert gv.carrier_com_offset(PARAMS) == pytest.approx(0.3, rel=1e-14)
    assert gv.cylinder_offset(PARAMS) == pytest.approx(150.0 / 495.0, rel=1e-14)


@pytest.mark.parametrize("t", [0.0, 3.0, 7.5, 12.5, 15.708, 25.0])
def test_carrier_inertia_about_O_matches_paper(model, t):
    alpha = 0.1 * t
    inertia = _inertia_from_model_fields(model, ("bus", "rod"), alpha)
    # Bezglasny & Khudyakova, worked example: I1x, I1y, I1z about O (carrier axes).
    paper = np.array([210 + ROD * np.cos(alpha) ** 2, 210 + ROD, 247.5 + ROD * np.sin(alpha) ** 2])
    np.testing.assert_allclose(np.diag(inertia), paper, rtol=5e-3)
    # Exact for the shapes: the paper's 210 = 165 + 500 * 0.3^2 puts the rod's mass at O1;
    # with the rod at O it is 165 + 495 d^2 = 210.4545 (+0.216 %).
    exact = np.array([165 + STEINER_1 + ROD * np.cos(alpha) ** 2, 165 + STEINER_1 + ROD, 247.5 + ROD * np.sin(alpha) ** 2])
    # (to the rod's 1e-9 kg m^2 axial floor, see gv.ROD_AXIAL_FLOOR_KG_M2)
    np.testing.assert_allclose(np.diag(inertia), exact, rtol=0, atol=1.1 * gv.ROD_AXIAL_FLOOR_KG_M2)
    assert (inertia[0, 0] - paper[0]) / paper[0] == pytest.approx(0.4545454545 / 210, rel=1e-3, abs=1e-5)
    # The tilted rod adds a product of inertia the paper's principal-axis form leaves out.
    assert inertia[0, 2] == pytest.approx(-ROD * np.sin(alpha) * np.cos(alpha), abs=1.1 * gv.ROD_AXIAL_FLOOR_KG_M2)
    # The module's kinematics-based computation agrees with the field-by-field one.
    data = mujoco.MjData(model)
    data.qpos[model.joint("rod_hinge").qposadr[0]] = alpha
    mujoco.mj_kinematics(model, data)
    np.testing.assert_allclose(gv.inertia_about_point(model, data, ("bus", "rod"), "bus"), inertia, atol=1e-11)


@pytest.mark.parametrize("sigma", [0.0, 1.0, 2.5])
def test_rotor_inertia_about_O_matches_paper(model, sigma):
    gyro = VariableGyrostatPlant(model, PARAMS)
    gyro.data.qpos[model.joint("rotor_hinge").qposadr[0]] = sigma
    gyro.data.qpos[3:7] = quat_from_axis_angle([0.6, 0.0, 0.8], 0.7)  # any carrier attitude
    mujoco.mj_kinematics(model, gyro.data)
    # I2x = 300 (1/4 + 0.25/12) + 75 = 156.25, I2y = 300 (0.16 + 0.25/12) + 75 = 129.25,
    # I2z = 300 (0.64 + 1)/4 = 123: about O, in the rotor's axes x2 y2 z2 (paper: exact).
    np.testing.assert_allclose(gyro.rotor_inertia(), np.diag([156.25, 129.25, 123.0]), atol=1e-11)


def test_prescribed_motion_is_tracked_and_momentum_conserved(model):
    gyro = VariableGyrostatPlant(model, PARAMS)
    gyro.reset(omega_body=[0.05, 0.03, 0.2])
    momentum0 = gyro.angular_momentum_world()
    worst = {"rod": 0.0, "rotor": 0.0}
    for _ in range(200):
        gyro.step(50)
        for name, err in gyro.tracking_error().items():
            worst[name] = max(worst[name], abs(err))
    assert gyro.time == pytest.approx(10.0)
    # Measured: rod 1.8e-5 rad, rotor 1.1e-7 rad (wn = 50 rad/s, integrated reference angles).
    assert worst["rod"] < 5e-5 and worst["rotor"] < 5e-6
    # Servos are internal torques: total momentum about the CoM is conserved (RK4).
    drift = np.linalg.norm(gyro.angular_momentum_world() - momentum0) / np.linalg.norm(momentum0)
    assert drift < 1e-9


def test_build_refuses_a_servo_too_fast_for_the_step():
    params = schema.load(gv.VariableGyrostatParams, {"servo_bandwidth_rad_s": 1000.0})
    with pytest.raises(InputError, match="servo_bandwidth_rad_s"):
        gv.build(params, dt=1e-3)


# --- Euler angles ------------------------------------------------------------------------

RNG = np.random.default_rng(2)
ANGLES = [np.array([RNG.uniform(-np.pi, np.pi), RNG.uniform(-np.pi, np.pi), RNG.uniform(0.05, np.pi - 0.05)])
          for _ in range(50)]


def test_sequence_is_z_x_z_precession_nutation_proper_rotation():
    for phi, psi, theta in ANGLES[:10]:
        expected = Rotation.from_euler("ZXZ", [psi, theta, phi]).as_matrix()  # intrinsic: Rz(psi) Rx(theta) Rz(phi)
        quat = quat_from_euler([phi, psi, theta])
        mat = np.zeros(9)
        mujoco.mju_quat2Mat(mat, quat)
        np.testing.assert_allclose(mat.reshape(3, 3), expected, atol=1e-14)
        # Nutation is the angle between body z and world Z.
        assert np.arccos(quat_rotate(quat, [0, 0, 1])[2]) == pytest.approx(theta, abs=1e-7)


def test_round_trips():
    for angles in ANGLES:
        quat = quat_from_euler(angles)
        np.testing.assert_allclose(euler_from_quat(quat), angles, atol=1e-12)
        np.testing.assert_allclose(euler_from_quat(-quat), angles, atol=1e-12)  # q and -q
        rates = RNG.normal(size=3)
        np.testing.assert_allclose(angle_rates(angles, body_rates(angles, rates)), rates, atol=1e-12)
        np.testing.assert_allclose(body_rates(angles, angle_rates(angles, rates)), rates, atol=1e-12)
    for q in RNG.normal(size=(20, 4)):
        q /= np.linalg.norm(q)
        back = quat_from_euler(euler_from_quat(q))
        assert min(np.abs(back - q).max(), np.abs(back + q).max()) < 1e-12


def test_gimbal_lock_is_refused_for_rates():
    with pytest.raises(ValueError, match="singular"):
        angle_rates([0.3, 0.2, 0.0], [0.1, 0.2, 0.3])
    np.testing.assert_allclose(euler_from_quat(quat_from_euler([0.4, 0.0, 0.0])), [0.4, 0.0, 0.0], atol=1e-15)


def test_angles_follow_mujoco_quaternion_kinematics():
    """A torque-free MuJoCo body (RK4) against solve_ivp of Euler's equations plus the
    angle-rate formulas, and MuJoCo's body rates against the rate formulas applied to
    finite differences of the angles read from its quaternions."""
    inertia = np.array([3.0, 4.0, 6.0])
    omega0 = np.array([0.4, -0.3, 1.1])
    angles0 = np.array([0.3, -0.5, 0.9])
    spec = mujoco.MjSpec()
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
    spec.option.timestep = 1e-3
    spec.option.gravity = [0.0, 0.0, 0.0]
    body = spec.worldbody.add_body(name="body", mass=1.0, inertia=inertia)
    body.add_freejoint()
    model = spec.compile()
    data = mujoco.MjData(model)
    data.qpos[3:7] = quat_from_euler(angles0)
    data.qvel[3:6] = omega0

    def rhs(_, s):
        w = s[:3]
        return np.concatenate([-np.cross(w, inertia * w) / inertia, angle_rates(s[3:], w)])

    times = np.arange(1, 11) * 1.0
    ref = solve_ivp(rhs, (0, times[-1]), np.concatenate([omega0, angles0]), method="DOP853",
                    rtol=1e-12, atol=1e-12, t_eval=times)
    assert ref.success
    h = 1e-3
    for k, t in enumerate(times):
        steps = int(round(t / h)) - int(round(data.time / h)) - 1
        mujoco.mj_step(model, data, nstep=steps)
        before = euler_from_quat(data.qpos[3:7])
        mujoco.mj_step(model, data)
        angles, omega = euler_from_quat(data.qpos[3:7]), data.qvel[3:6].copy()
        assert np.sin(angles[2]) > 0.2  # well away from gimbal lock
        diff = angles - ref.y[3:, k]
        np.testing.assert_allclose(np.arctan2(np.sin(diff), np.cos(diff)), 0.0, atol=1e-8)
        mujoco.mj_step(model, data)
        after = euler_from_quat(data.qpos[3:7])
        central = np.arctan2(np.sin(after - before), np.cos(after - before)) / (2 * h)
        np.testing.assert_allclose(body_rates(angles, central), omega, atol=1e-6)
        np.testing.assert_allclose(omega, ref.y[:3, k], atol=1e-9)
