"""Satellite with four single-gimbal CMGs in the rhombus layout of SEEDS §004
(models/cmg_rhombus.xml).

Three parts, each with one job:
- `CmgRhombusParams` + `build`: apply every parameter to the MJCF with MjSpec;
- `ClusterGeometry`: the cluster's axes, rotor momenta, H(beta) and dH/dbeta, all read back
  from a compiled model (never typed in a second time);
- `CmgRhombus`: joint / actuator addresses by name and the state read-outs a run needs.

Geometry (SEEDS §004): CMG i has spin axis cos(b_i) e_i + sin(b_i) s_i z with
e1 = (cos a, sin a, 0), e2 = (-cos a, sin a, 0), e3 = -e1, e4 = -e2, s = (+1, +1, -1, -1),
gimbal axis g_i = s_i (e_i x z). Rodrigues' formula about g_i gives
R(b) e_i = cos b e_i + sin b (g_i x e_i), and g_i x e_i = s_i z, so a positive MuJoCo hinge
angle b_i about g_i is exactly the paper's b_i.
"""

from dataclasses import dataclass

import mujoco
import numpy as np

from testbed.domains.satellite import (
    BUS_BODY, MODELS_DIR, FreeBus, apply_bus_params, positive_scalar, principal_inertia)
from testbed.errors import InputError
from testbed.quaternion import quat_to_matrix

CMG_RHOMBUS_XML = MODELS_DIR / "cmg_rhombus.xml"
N_CMG = 4
GIMBALS = tuple(f"gimbal{i}" for i in range(1, N_CMG + 1))  # body and joint names
ROTORS = tuple(f"rotor{i}" for i in range(1, N_CMG + 1))  # body and joint names
GIMBAL_SERVOS = tuple(f"gimbal_rate{i}" for i in range(1, N_CMG + 1))
ROTOR_SERVOS = tuple(f"rotor_speed{i}" for i in range(1, N_CMG + 1))
ROTOR_SPEED_NUMERIC = "rotor_nominal_speed"
INITIAL_KEY = "initial"
SIGNS = np.array([1.0, 1.0, -1.0, -1.0])  # s_i of SEEDS §004

# RK4 stays accurate and stable for the servo modes when (rate x dt) is well below its
# stability limit 2.8; DESIGN.md measured divergence at w_n dt ~ 1 and good tracking at 0.3-0.6.
MAX_SERVO_OMEGA_DT = 0.7
MAX_DT_OVER_ROTOR_TAU = 0.5


@dataclass(frozen=True)
class CmgRhombusParams:
    """Parameters of the CMG spacecraft (SI units, radians).

    bus_inertia: principal inertia of the bus alone about its CoM [kg m^2]; the system inertia
        also contains the CMG masses at distance cmg_distance and their own inertias
        (see CmgRhombus.system_inertia).
    alpha: rhombus angle of SEEDS §004 eq. (15) [rad].
    rotor_momentum: h, spin momentum of one rotor at the nominal speed [N m s].
    rotor_speed_rpm: nominal rotor speed relative to its gimbal [rpm]; rotor spin inertia
        Js = h / Omega.
    rotor_transverse_ratio: rotor transverse inertia / spin inertia (0.5 for a thin disk).
    gimbal_inertia: gimbal frame principal inertia about (gimbal axis, spin axis at beta = 0,
        third axis) [kg m^2].
    servo_natural_frequency, servo_damping_ratio: gimbal-rate servo w_n [rad/s] and zeta;
        kp = J w_n^2, kv = 2 zeta w_n J with J the inertia about the gimbal axis (gimbal frame
        + rotor transverse), so the servo's dynamics do not change with the inertias.
    rotor_speed_time_constant: tau of the rotor speed loop [s]; kv = Js / tau.
    beta0: initial gimbal angles [rad]; default is the zero-momentum, full-rank set
        (45, -45, -45, 45) deg.
    """

    bus_inertia: tuple = (800.0, 1000.0, 1200.0)
    bus_mass: float = 1000.0
    timestep: float = 1e-3
    integrator: str = "RK4"
    alpha: float = float(np.arctan(np.sqrt(2.0)))
    rotor_momentum: float = 50.0
    rotor_speed_rpm: float = 6000.0
    rotor_transverse_ratio: float = 0.6
    rotor_mass: float = 10.0
    gimbal_inertia: tuple = (0.03, 0.02, 0.02)
    gimbal_mass: float = 5.0
    cmg_distance: float = 0.5
    servo_natural_frequency: float = 316.0
    servo_damping_ratio: float = 1.0
    rotor_speed_time_constant: float = 0.02
    beta0: tuple = (np.pi / 4, -np.pi / 4, -np.pi / 4, np.pi / 4)

    @property
    def rotor_speed(self):
        """Nominal rotor speed [rad/s]."""
        return self.rotor_speed_rpm * 2.0 * np.pi / 60.0


def rhombus_axes(alpha):
    """Unit vectors of SEEDS §004 in the bus frame: e_i (spin at beta = 0), g_i = s_i e_i x z
    (gimbal) and s_i z (where the spin axis turns for beta > 0); each (4, 3)."""
    c, s = np.cos(alpha), np.sin(alpha)
    e = np.array([[c, s, 0.0], [-c, s, 0.0], [-c, -s, 0.0], [c, -s, 0.0]])
    z = np.array([0.0, 0.0, 1.0])
    g = SIGNS[:, None] * np.cross(e, z)
    return e, g, SIGNS[:, None] * z


def build(params: CmgRhombusParams) -> mujoco.MjModel:
    """Compile models/cmg_rhombus.xml with every field of `params` applied through MjSpec."""
    spec = mujoco.MjSpec.from_file(str(CMG_RHOMBUS_XML))
    apply_bus_params(spec, params.bus_inertia, params.bus_mass, params.timestep,
                     params.integrator)
    alpha = float(params.alpha)
    if not 0.0 < alpha < np.pi / 2:
        raise InputError("alpha", f"must lie in (0, pi/2) rad, got {alpha}")
    h = positive_scalar("rotor_momentum", params.rotor_momentum)
    omega_rotor = positive_scalar("rotor_speed_rpm", params.rotor_speed_rpm) * np.pi / 30.0
    ratio = positive_scalar("rotor_transverse_ratio", params.rotor_transverse_ratio)
    if ratio < 0.5:  # a body of revolution has Jt >= Js / 2
        raise InputError("rotor_transverse_ratio", f"must be >= 0.5 for a rotor, got {ratio}")
    rotor_mass = positive_scalar("rotor_mass", params.rotor_mass)
    gimbal_inertia = principal_inertia("gimbal_inertia", params.gimbal_inertia)
    gimbal_mass = positive_scalar("gimbal_mass", params.gimbal_mass)
    distance = positive_scalar("cmg_distance", params.cmg_distance)
    beta0 = np.asarray(params.beta0, dtype=float)
    if beta0.shape != (N_CMG,) or not np.all(np.isfinite(beta0)):
        raise InputError("beta0", f"expected {N_CMG} finite angles, got {params.beta0}")

    spin_inertia = h / omega_rotor
    rotor_inertia = np.array([ratio, ratio, 1.0]) * spin_inertia  # rotor spin axis = local z
    gimbal_axis_inertia = gimbal_inertia[0] + rotor_inertia[0]  # rotor transverse about g
    kp, kv = servo_gains(params, gimbal_axis_inertia)
    tau = positive_scalar("rotor_speed_time_constant", params.rotor_speed_time_constant)
    if params.timestep / tau > MAX_DT_OVER_ROTOR_TAU:
        raise InputError("rotor_speed_time_constant",
                         f"{tau} s is too short for timestep {params.timestep} s under RK4")
    rotor_kv = spin_inertia / tau

    e, g, sz = rhombus_axes(alpha)
    for i in range(N_CMG):
        gimbal = spec.body(GIMBALS[i])
        gimbal.pos = distance * e[i]
        # gimbal frame: x = g_i (hinge axis in the XML), y = e_i (rotor spin), z = s_i z
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, np.column_stack([g[i], e[i], sz[i]]).ravel())
        gimbal.quat = quat
        gimbal.mass = gimbal_mass
        gimbal.inertia = gimbal_inertia
        gimbal.ipos = np.zeros(3)
        rotor = spec.body(ROTORS[i])
        rotor.mass = rotor_mass
        rotor.inertia = rotor_inertia
        rotor.ipos = np.zeros(3)

        servo = spec.actuator(GIMBAL_SERVOS[i])
        servo.gainprm = _with_first(servo.gainprm, [kp])
        servo.biasprm = _with_first(servo.biasprm, [0.0, -kp, -kv])
        speed = spec.actuator(ROTOR_SERVOS[i])
        speed.gainprm = _with_first(speed.gainprm, [rotor_kv])
        speed.biasprm = _with_first(speed.biasprm, [0.0, 0.0, -rotor_kv])

    spec.numeric(ROTOR_SPEED_NUMERIC).data = [omega_rotor]
    _write_initial_key(spec, beta0, omega_rotor)
    return spec.compile()


def servo_gains(params, gimbal_axis_inertia):
    """(kp, kv) of the integrated-velocity gimbal servo: the closed loop
    J b'' + kv b' + kp b = kp b_cmd has natural frequency w_n and damping ratio zeta.

    kv damps the absolute gimbal rate (not the rate error), so a sinusoidal rate command of
    frequency w is tracked with a relative error of about 2 zeta w / w_n (0.4 % at 0.1 Hz
    for the defaults); a steady rate is tracked exactly, with a constant angle lag."""
    w_n = positive_scalar("servo_natural_frequency", params.servo_natural_frequency)
    zeta = positive_scalar("servo_damping_ratio", params.servo_damping_ratio)
    if w_n * params.timestep > MAX_SERVO_OMEGA_DT:
        raise InputError("servo_natural_frequency",
                         f"w_n dt = {w_n * params.timestep:.3f} exceeds {MAX_SERVO_OMEGA_DT}: "
                         "RK4 would be inaccurate or unstable")
    return gimbal_axis_inertia * w_n**2, 2.0 * zeta * w_n * gimbal_axis_inertia


def _with_first(array, values):
    """Copy of `array` with its first entries replaced by `values`."""
    out = np.array(array, dtype=float)
    out[:len(values)] = values
    return out


def _write_initial_key(spec, beta0, omega_rotor):
    """Keyframe "initial": bus at rest at the origin, gimbals at beta0 with servo activations
    equal to beta0 (so the servos start without a position error), rotors at nominal speed."""
    key = spec.key(INITIAL_KEY)
    qpos = [0, 0, 0, 1, 0, 0, 0]
    qvel = [0.0] * 6
    for b in beta0:
        qpos += [b, 0.0]
        qvel += [0.0, omega_rotor]
    key.qpos = qpos
    key.qvel = qvel
    key.act = list(beta0)
    key.ctrl = [0.0] * 3 + [0.0] * N_CMG + [omega_rotor] * N_CMG


class ClusterGeometry:
    """CMG cluster geometry read from a compiled model, in the bus frame.

    gimbal_axes g_i, spin_axes_zero e_i (spin at beta = 0), turn_axes = g_i x e_i (= s_i z):
    (4, 3) unit vectors. spin_inertia Js_i [kg m^2], nominal_rotor_speed Omega [rad/s],
    rotor_momentum h_i = Js_i Omega (4,), h: the common value of h_i [N m s].
    """

    def __init__(self, gimbal_axes, spin_axes_zero, spin_inertia, nominal_rotor_speed):
        self.gimbal_axes = np.asarray(gimbal_axes, dtype=float)
        self.spin_axes_zero = np.asarray(spin_axes_zero, dtype=float)
        self.turn_axes = np.cross(self.gimbal_axes, self.spin_axes_zero)
        self.spin_inertia = np.asarray(spin_inertia, dtype=float)
        self.nominal_rotor_speed = float(nominal_rotor_speed)
        self.rotor_momentum = self.spin_inertia * self.nominal_rotor_speed
        if np.ptp(self.rotor_momentum) > 1e-12 * self.rotor_momentum.max():
            raise ValueError(f"rotor momenta differ: {self.rotor_momentum}")
        self.h = float(self.rotor_momentum.mean())

    @classmethod
    def from_model(cls, model):
        """Axes from body quaternions and joint axes, Js from the rotor inertials (the inertia
        about the spin axis), Omega from the custom numeric "rotor_nominal_speed"."""
        bus_id = model.body(BUS_BODY).id
        gimbal_axes, spin_axes, spin_inertia = [], [], []
        for gimbal_name, rotor_name in zip(GIMBALS, ROTORS):
            gimbal, rotor = model.body(gimbal_name), model.body(rotor_name)
            if gimbal.parentid[0] != bus_id or rotor.parentid[0] != gimbal.id:
                raise ValueError(f"{rotor_name} must sit in {gimbal_name}, which sits in bus")
            to_bus = quat_to_matrix(gimbal.quat)  # gimbal frame -> bus frame
            rotor_to_bus = to_bus @ quat_to_matrix(rotor.quat)
            rotor_axis = model.jnt_axis[model.joint(rotor_name).id]  # rotor frame
            gimbal_axes.append(to_bus @ model.jnt_axis[model.joint(gimbal_name).id])
            spin_axes.append(rotor_to_bus @ rotor_axis)
            inertial = quat_to_matrix(rotor.iquat)  # principal frame -> rotor frame
            inertia_rotor_frame = inertial @ np.diag(rotor.inertia) @ inertial.T
            spin_inertia.append(rotor_axis @ inertia_rotor_frame @ rotor_axis)
        speed = model.numeric(ROTOR_SPEED_NUMERIC).data[0]
        return cls(gimbal_axes, spin_axes, spin_inertia, speed)

    @property
    def alpha(self):
        """Rhombus angle a of SEEDS §004, from e_1 = (cos a, sin a, 0)."""
        return float(np.arctan2(self.spin_axes_zero[0, 1], self.spin_axes_zero[0, 0]))

    def spin_axes(self, beta):
        """Unit spin axes at gimbal angles beta, (..., 4, 3): cos b_i e_i + sin b_i s_i z."""
        beta = np.asarray(beta, dtype=float)[..., None]
        return np.cos(beta) * self.spin_axes_zero + np.sin(beta) * self.turn_axes

    def momentum(self, beta, rotor_rates=None):
        """Total rotor spin momentum H(beta) = sum_i h_i (cos b_i e_i + sin b_i s_i z) in the
        bus frame [N m s] (SEEDS §004 eq. (15)); with rotor_rates, h_i = Js_i Omega_i.
        Leading dimensions of beta and rotor_rates (e.g. a recorded history) broadcast."""
        h = self.rotor_momentum if rotor_rates is None else (
            self.spin_inertia * np.asarray(rotor_rates, dtype=float))
        return (h[..., None, :] @ self.spin_axes(beta))[..., 0, :]

    def unit_jacobian(self, beta):
        """dH/dbeta per unit rotor momentum, (3, 4): column i = -sin b_i e_i + cos b_i s_i z
        (SEEDS §004 eq. (18) divided by h). Steering solves h J(b) b' = H' (eq. (17))."""
        beta = np.asarray(beta, dtype=float)[:, None]
        return (-np.sin(beta) * self.spin_axes_zero + np.cos(beta) * self.turn_axes).T

    def jacobian(self, beta):
        """dH/dbeta at the nominal rotor momenta [N m s / rad], (3, 4): h_i times unit column."""
        return self.unit_jacobian(beta) * self.rotor_momentum

    def singularity_measure(self, beta):
        """sqrt(det(J J^T)) of the unit Jacobian: 0 at a singular set, up to (4/3)^(3/2)."""
        j = self.unit_jacobian(beta)
        return float(np.sqrt(max(np.linalg.det(j @ j.T), 0.0)))


class CmgRhombus(FreeBus):
    """The compiled CMG spacecraft, known by joint and actuator names."""

    def __init__(self, model):
        super().__init__(model)
        self.geometry = ClusterGeometry.from_model(model)
        gimbal_joints = [model.joint(n) for n in GIMBALS]
        rotor_joints = [model.joint(n) for n in ROTORS]
        self.gimbal_qpos_adr = np.array([j.qposadr[0] for j in gimbal_joints])
        self.gimbal_qvel_adr = np.array([j.dofadr[0] for j in gimbal_joints])
        self.rotor_qpos_adr = np.array([j.qposadr[0] for j in rotor_joints])
        self.rotor_qvel_adr = np.array([j.dofadr[0] for j in rotor_joints])
        self.gimbal_actuator_ids = np.array([model.actuator(n).id for n in GIMBAL_SERVOS])
        self.gimbal_act_adr = model.actuator_actadr[self.gimbal_actuator_ids]
        self.rotor_actuator_ids = np.array([model.actuator(n).id for n in ROTOR_SERVOS])
        self.initial_key_id = model.key(INITIAL_KEY).id
        # every dof that is not the bus free joint belongs to a gimbal or a rotor
        bus_dofs = set(range(self.qvel_adr, self.qvel_adr + 6))
        self.internal_dofs = np.array([i for i in range(model.nv) if i not in bus_dofs])

    def gimbal_angles(self, data):
        """Gimbal angles beta [rad], (4,)."""
        return data.qpos[self.gimbal_qpos_adr].copy()

    def gimbal_rates(self, data):
        """Gimbal rates beta' [rad/s], (4,)."""
        return data.qvel[self.gimbal_qvel_adr].copy()

    def rotor_rates(self, data):
        """Rotor speeds relative to their gimbals Omega [rad/s], (4,)."""
        return data.qvel[self.rotor_qvel_adr].copy()

    def set_gimbal_rate_command(self, data, rates):
        """Command gimbal rates [rad/s]; the servo integrates them into an angle set-point."""
        data.ctrl[self.gimbal_actuator_ids] = np.asarray(rates, dtype=float)

    def set_rotor_speed_command(self, data, speeds):
        """Command relative rotor speeds [rad/s]."""
        data.ctrl[self.rotor_actuator_ids] = np.asarray(speeds, dtype=float)

    def initialise(self, data, omega0_body, quat0, beta0=None, rotor_speed=None):
        """Reset to keyframe "initial" (beta0 and nominal rotor speed from build), then set the
        bus attitude quat0 and body rate omega0_body, optionally other gimbal angles beta0
        and rotor speeds; servo activations = gimbal angles, gimbal commands 0; mj_forward."""
        mujoco.mj_resetDataKeyframe(self.model, data, self.initial_key_id)
        if beta0 is not None:
            beta0 = np.asarray(beta0, dtype=float)
            if beta0.shape != (N_CMG,) or not np.all(np.isfinite(beta0)):
                raise InputError("beta0", f"expected {N_CMG} finite angles, got {beta0}")
            data.qpos[self.gimbal_qpos_adr] = beta0
        if rotor_speed is not None:
            speeds = np.broadcast_to(np.asarray(rotor_speed, dtype=float), (N_CMG,))
            if not np.all(np.isfinite(speeds)):
                raise InputError("rotor_speed", f"expected finite speeds, got {rotor_speed}")
            data.qvel[self.rotor_qvel_adr] = speeds
            self.set_rotor_speed_command(data, speeds)
        # the servo set-point is its activation: it must start at the actual angle
        data.act[self.gimbal_act_adr] = data.qpos[self.gimbal_qpos_adr]
        data.qvel[self.gimbal_qvel_adr] = 0.0
        self.set_gimbal_rate_command(data, np.zeros(N_CMG))
        self.set_free_joint_state(data, omega0_body, quat0)
        mujoco.mj_forward(self.model, data)

    def internal_momentum_body(self, data):
        """Angular momentum of the gimbals and rotors relative to the bus, bus frame [N m s].

        The bus-rotation row of the mass matrix times the gimbal and rotor joint rates:
        sum_k I_k w_rel,k (+ m_k r_k x v_rel,k, zero here since every CoM lies on its
        joint axis). Includes the gimbal-rate terms, unlike the spin-only H(beta).
        """
        self.refresh(data)
        mass_matrix = np.zeros((self.model.nv, self.model.nv))
        mujoco.mj_fullM(self.model, data, mass_matrix)
        a = self.qvel_adr + 3
        rows = mass_matrix[a:a + 3][:, self.internal_dofs]
        return rows @ data.qvel[self.internal_dofs]
