"""The regulation laws against closed forms: the eigen-axis slew at the rate limit, the MRP law's
small-error response and Lyapunov function, and the internal momentum a law reads."""

import numpy as np
import pytest

import testbed
from testbed.math.quaternion import quat_angle, quat_conj, quat_mul

AXIS = np.ones(3) / np.sqrt(3)
ARCSEC = np.pi / (180.0 * 3600.0)
RIGID = {"name": "mrp_rigid", "model": {"system": "satellite", "inertia_kg_m2": [800, 1000, 1200], "mass_kg": 500},
         "initial": {"quat": [1, 0, 0, 0]}, "sim": {"duration_s": 60, "dt_s": 0.01, "control_period_s": 0.01},
         "pipeline": {"sensor": {"type": "ideal_attitude"}, "estimator": {"type": "attitude"},
                      "allocator": {"type": "ideal_torque"}}}


@pytest.fixture(scope="module")
def ideal():
    return testbed.run("slew_quaternion_feedback_ideal")


@pytest.mark.slow
def test_quaternion_feedback_turns_about_the_eigen_axis_at_the_rate_limit(ideal):
    t, omega = ideal.trace["truth/omega"]
    _, limited = ideal.trace["law/rate_limited"]
    n = len(limited)
    turning = (limited[:, 0] == 1) & (t[:n] > 25)          # saturated, past the first 20 s of spin-up
    rates = omega[:n][turning]
    assert len(rates) > 50
    # the eigen-axis: the body rate stays along the slew axis, to 0.1 deg
    direction = np.degrees(np.arccos(np.clip(rates @ AXIS / np.linalg.norm(rates, axis=1), -1, 1)))
    assert np.max(direction) < 0.1
    # at the rate limit L = 1.5 deg/s (rate loop time constant 1/c = 2.8 s, the torque scaled to 0.86 at first): 1 %
    assert np.degrees(np.linalg.norm(rates, axis=1)) == pytest.approx(1.5, rel=0.01)
    # at rest on the target: the closed loop's exponential decay down to the round-off floor (1e-6 deg band)
    assert ideal.metrics["final_pointing_error_deg"] < 1e-6


@pytest.mark.slow
def test_law_reads_the_momentum_the_cluster_holds(ideal):
    # the law's input (MuJoCo's bus-rotation row of the mass matrix times the joint rates) against the
    # steering's own sum of the rotor and gimbal momenta (ClusterGeometry.held_momentum): two methods
    _, law = ideal.trace["law/internal_momentum"]
    _, held = ideal.trace["allocator/held_momentum"]
    rows = np.all(np.isfinite(law), axis=1)
    assert np.max(np.abs(law[rows])) > 10.0                  # the slew stores up to 26 N m s in the cluster
    assert np.max(np.abs(law[rows] - held[rows])) < 1e-9 * np.max(np.abs(held[rows]))


def _mrp(k, p, axis, angle, duration=60.0):
    data = RIGID | {"sim": RIGID["sim"] | {"duration_s": duration}}
    data["pipeline"] = RIGID["pipeline"] | {"law": {"type": "mrp_feedback", "gain_k_nm": k, "gain_p_nms": p,
                                                      "axis": axis, "angle_deg": angle}}
    return testbed.run(data)


def test_mrp_small_error_follows_the_second_order_closed_form():
    # 1 deg about x: I θ'' = -(K/4) θ - P θ' (σ ≈ θ/4), from θ(0) = -1 deg (the target is +1 deg away)
    k, p, inertia = 80.0, 177.0, 800.0
    result = _mrp(k, p, [1, 0, 0], 1.0, duration=40.0)
    t, error = result.trace["law/attitude_error"]
    wn, zeta = np.sqrt(k / 4 / inertia), p / (2 * np.sqrt(k / 4 * inertia))   # 0.158 rad/s, 0.70
    wd = wn * np.sqrt(1 - zeta**2)
    theta0 = -np.radians(1.0)
    closed = theta0 * np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t))
    rows = np.isfinite(error[:, 0])
    # the MRP's cubic term (σ = tan(θ/4)) is 2e-5 of θ at 1 deg: a band of 1e-3 of the start error
    assert np.max(np.abs(error[rows, 0] - closed[rows])) < 1e-3 * abs(theta0)


def test_mrp_lyapunov_function_never_increases_on_a_large_slew():
    # Schaub & Junkins: V = ½ ωᵀIω + 2K ln(1 + σᵀσ), V' = -P ωᵀω <= 0, from 170 deg away
    k, p = 20.0, 150.0
    result = _mrp(k, p, list(AXIS), 170.0, duration=60.0)
    t, sigma = result.trace["law/mrp_error"]
    omega = result.trace["truth/omega"][1][: len(t)]
    rows = np.all(np.isfinite(sigma), axis=1)
    inertia = np.diag([800.0, 1000.0, 1200.0])
    v = 0.5 * np.einsum("ni,ij,nj->n", omega[rows], inertia, omega[rows]) + 2 * k * np.log1p(np.sum(sigma[rows]**2, 1))
    # RK4 at dt 0.01 s and a held torque: V may rise by round-off and the hold only, 1e-6 of V(0)
    assert np.max(np.diff(v)) < 1e-6 * v[0]
    assert v[-1] < 0.05 * v[0]


@pytest.mark.slow
def test_mekf_in_the_loop_points_as_its_rate_noise_predicts(ideal):
    mekf = testbed.run("slew_quaternion_feedback_mekf")
    assert mekf.status == "ok"
    # per axis x'' + c x' + k x = -c n, n the gyro's white rate noise of density σ_v: var x = c σ_v² / (2 k)
    # (a second-order system driven by white noise); three axes alike
    c, k, arw = 2 * 0.9 * 0.2, 0.2**2, 4.4e-5
    predicted = np.sqrt(3 * c * arw**2 / (2 * k))                       # 33.3 arcsec
    t, quat = mekf.trace["truth/quat"]
    target = mekf.data.statistics["law"]["target_quat"]
    error = quat_angle(quat_mul(quat_conj(target), quat))
    rms = np.sqrt(np.mean(error[t >= 100.0] ** 2))                      # 100 s of about 6 s correlation
    # about 17 independent stretches (±17 %); the knowledge error, correlated with the same gyro noise,
    # is left out of the prediction (measured 28.6 arcsec, -14 %)
    assert 0.7 * predicted < rms < 1.15 * predicted
    assert mekf.metrics["pointing_rms_last_20s_arcsec"] < 1.5 * predicted / ARCSEC
    assert mekf.metrics["final_pointing_error_deg"] < np.degrees(3 * predicted)
    # the ideal run of the same slew: at the round-off floor, a million times better
    assert ideal.metrics["pointing_rms_last_20s_arcsec"] < 1e-3


PLUGIN = '''
from dataclasses import dataclass
import numpy as np
import testbed


@dataclass(kw_only=True)
class HoldParams:
    natural_frequency_rad_s: float = testbed.param(0.3, gt=0)


@testbed.stage("law", "user.momentum_hold", HoldParams)
class MomentumHold:
    """A user's PD hold of the start attitude that cancels w x (I w + H) itself."""

    inputs = ("internal_momentum",)

    @classmethod
    def design(cls, params):
        return {"compensates_internal_momentum": True}

    def __init__(self, params, ctx):
        self.inertia = np.asarray(ctx.inertia, float)
        self.kp, self.kd = 2 * params.natural_frequency_rad_s**2, 2 * params.natural_frequency_rad_s

    def torque(self, t, inputs):
        q, w, h = inputs["quat"], inputs["omega"], inputs["internal_momentum"]
        e = q[1:] if q[0] >= 0 else -q[1:]
        u = -self.inertia @ (self.kp * e + self.kd * w) + np.cross(w, self.inertia @ w + h)
        return {"torque": u, "h": h}
'''


@pytest.mark.slow
def test_a_users_law_reads_the_cluster_momentum_and_decouples_the_axes(tmp_path):
    (tmp_path / "hold.py").write_text(PLUGIN)
    wn = 0.3
    data = {"name": "user_hold", "plugins": [str(tmp_path / "hold.py")],
            "model": {"system": "cmg_rhombus", "inertia_kg_m2": [800, 1000, 1200], "rotor_momentum_nms": 25,
                      "gimbal_angles_deg": [45, -45, -45, -45], "servo_model": "feedforward",
                      "servo_natural_frequency_rad_s": 5},
            "initial": {"quat": [1, 0, 0, 0], "omega_deg_s": [0.02, 0, 0]},
            "sim": {"duration_s": 20, "dt_s": 0.01, "control_period_s": 0.05},
            "pipeline": {"sensor": {"type": "ideal_attitude"}, "estimator": {"type": "attitude"},
                         "law": {"type": "user.momentum_hold", "natural_frequency_rad_s": wn},
                         "allocator": {"type": "minimax", "beta_rate_max_deg_s": 10}}}
    result = testbed.run(data)
    assert result.status == "ok"
    _, h = result.trace["law/h"]
    rows = np.all(np.isfinite(h), axis=1)
    assert np.linalg.norm(h[rows][0]) > 35.0          # the stored momentum the law must cancel
    _, held = result.trace["allocator/held_momentum"]
    assert np.max(np.abs(h[rows] - held[rows])) < 1e-9 * np.max(np.abs(held[rows]))
    # cancelled: each axis obeys θ'' + 2 ωn θ' + ωn² θ = 0 (θ = 2 e, critical damping) by itself, so
    # the x rate decays as ω0 (1 - ωn t) e^(-ωn t) and y, z stay at rest; with |H| = 35 N m s
    # uncompensated the x rate would spill into y and z at |H| ω0 / I ~ 1e-5 rad/s^2
    t, omega = result.trace["truth/omega"]
    w0 = np.radians(0.02)
    closed = w0 * (1 - wn * t) * np.exp(-wn * t)
    # the held torque over 0.05 s (ωn Tc = 0.015) sets the band: 3 % of ω0 (measured 0.7 %); across,
    # 0.5 % (measured 0.05 %), where the uncompensated spill would reach 3.5 % of ω0 within a second
    assert np.max(np.abs(omega[:, 0] - closed)) < 0.03 * w0
    assert np.max(np.abs(omega[:, 1:])) < 0.005 * w0
