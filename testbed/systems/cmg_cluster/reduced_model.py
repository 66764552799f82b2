"""Reduced (gyrostat) model of the CMG spacecraft, independent of MuJoCo's dynamics.

Given the gimbal angles beta(t), gimbal rates beta'(t) and rotor speeds Omega(t) that the
truth produced, it integrates the body rate w(t) of the bus.

Exact form used for the comparison with MuJoCo (free spacecraft, no external torque):
    L_b' = -w x L_b,      w = I_sys(beta)^-1 (L_b - H_int(beta, beta', Omega)),
where L_b is the total angular momentum about the system CoM in bus axes (L_world is
constant, L_b = R^T L_world), I_sys(beta) the locked inertia of bus + gimbals + rotors and
H_int = sum_i K_i(beta) g_i beta'_i + Js_i Omega_i a_i(beta) the momentum of the gimbals and
rotors relative to the bus (K_i = gimbal + rotor inertia of CMG i, g_i gimbal axis,
a_i spin axis). Differentiating L_b = I_sys w + H_int recovers SEEDS §004's
I w' + w x (I w + H) = -H' with the two terms the textbook form drops: I_sys changes with beta
when the rotor's transverse and spin inertias differ, and H contains the gimbals' own
momentum K_i g_i beta'_i besides the rotor spin momentum.

`textbook_cmg_omega` integrates that textbook form (constant I, H = sum h a_i(beta)) for
comparison.

On a hybrid bus H_int also holds the wheels' sum_j Jw_j Omega_j a_j (their locked inertia is
constant: each is axisymmetric about its axis, its CoM on it), from the recorded wheel speeds.

Mass properties come from the compiled model's arrays only (body_mass, body_ipos,
body_inertia, body_iquat, body_pos, body_quat, jnt_axis, jnt_pos); the cluster axes from
ClusterGeometry, which reads the same arrays.

Interpolation of the sampled histories (document of record):
- beta: piecewise cubic Hermite through (beta_k, beta'_k): C1, and consistent with beta';
- beta' and Omega: not-a-knot cubic splines (C2) through the samples;
- wheel speeds: piecewise linear (their motor torque is held over each control period).
With samples every physics step (1-2 ms) the interpolation error is far below 1e-9 rad/s.
"""

from dataclasses import dataclass

import mujoco
import numpy as np

from testbed.appendages.joints import is_appendage, locked_appendage_mass
from testbed.systems.free_bus import BUS_BODY
from testbed.systems.cmg_cluster.cluster import CLUSTER_SYSTEMS, ClusterGeometry, unit_count, unit_names
from testbed.math.quaternion import quat_to_matrix
from testbed.recording.reference_windows import WindowedReference
from testbed.references.registry import reference
from testbed.scenario.schema import param


def _rotation_about(axis, angle):
    """Rodrigues: rotation matrix by `angle` about unit `axis`."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def _distance_to_line(point, anchor, direction):
    offset = point - anchor
    return np.linalg.norm(offset - (offset @ direction) * direction)


class CmgMassModel:
    """Mass properties of the CMG spacecraft as functions of the gimbal angles, bus frame.

    system_inertia(beta) = I_const + sum_i R_i K_i R_i^T, with R_i the rotation by beta_i
    about g_i and K_i the inertia of gimbal i + rotor i about their own CoMs at beta = 0;
    I_const holds the bus and every parallel-axis term (constant because each CoM lies on
    the axes it turns about, which from_model checks).
    """

    def __init__(self, constant_inertia, cmg_inertia, gimbal_axes, spin_axes_zero,
                 spin_inertia, wheel_axes=np.zeros((0, 3)), wheel_spin_inertia=np.zeros(0)):
        self.constant_inertia = np.asarray(constant_inertia, dtype=float)
        self.cmg_inertia = np.asarray(cmg_inertia, dtype=float)  # (4, 3, 3)
        self.gimbal_axes = np.asarray(gimbal_axes, dtype=float)
        self.spin_axes_zero = np.asarray(spin_axes_zero, dtype=float)
        self.spin_inertia = np.asarray(spin_inertia, dtype=float)
        self.wheel_axes = np.asarray(wheel_axes, dtype=float)  # (m, 3): wheels hinged to the bus (a hybrid bus)
        self.wheel_spin_inertia = np.asarray(wheel_spin_inertia, dtype=float)  # (m,)

    @property
    def has_wheels(self) -> bool:
        return len(self.wheel_axes) > 0

    @classmethod
    def from_model(cls, model):
        """Read mass properties from a compiled CMG cluster model (positions at qpos = 0)."""
        geometry = ClusterGeometry.from_model(model)
        bus_id = model.body(BUS_BODY).id
        masses, coms, inertias = [model.body_mass[bus_id]], [model.body_ipos[bus_id]], []
        iframe = quat_to_matrix(model.body_iquat[bus_id])
        inertias.append(iframe @ np.diag(model.body_inertia[bus_id]) @ iframe.T)
        cmg_inertia = []
        for i, (gimbal_name, rotor_name) in enumerate(zip(*unit_names(unit_count(model)))):
            gimbal, rotor = model.body(gimbal_name), model.body(rotor_name)
            gimbal_rot = quat_to_matrix(gimbal.quat)
            rotor_rot = gimbal_rot @ quat_to_matrix(rotor.quat)
            gimbal_anchor = gimbal.pos + gimbal_rot @ model.jnt_pos[model.joint(gimbal_name).id]
            rotor_anchor = (gimbal.pos + gimbal_rot @ rotor.pos
                            + rotor_rot @ model.jnt_pos[model.joint(rotor_name).id])
            gimbal_com = gimbal.pos + gimbal_rot @ gimbal.ipos
            rotor_com = gimbal.pos + gimbal_rot @ rotor.pos + rotor_rot @ rotor.ipos
            cmg = np.zeros((3, 3))
            for body, rot, com in ((gimbal, gimbal_rot, gimbal_com),
                                   (rotor, rotor_rot, rotor_com)):
                # a CoM off its rotation axes would move the system CoM and the bus
                if _distance_to_line(com, gimbal_anchor, geometry.gimbal_axes[i]) > 1e-9:
                    raise ValueError(f"{body.name} CoM is off the gimbal axis")
                principal = rot @ quat_to_matrix(body.iquat)
                cmg += principal @ np.diag(body.inertia) @ principal.T
                masses.append(body.mass[0])
                coms.append(com)
            rotor_principal = rotor_rot @ quat_to_matrix(rotor.iquat)
            rotor_inertia = rotor_principal @ np.diag(rotor.inertia) @ rotor_principal.T
            if _distance_to_line(rotor_com, rotor_anchor, geometry.spin_axes_zero[i]) > 1e-9:
                raise ValueError(f"{rotor_name} CoM is off its spin axis")
            _check_axisymmetric(rotor_name, rotor_inertia, geometry.spin_axes_zero[i])
            cmg_inertia.append(cmg)
        wheel_axes, wheel_spin = [], []
        gimbal_ids = {model.body(name).id for name in unit_names(unit_count(model))[0]}
        for body_id in range(model.nbody):
            if (model.body_parentid[body_id] != bus_id or body_id in gimbal_ids or body_id == bus_id
                    or is_appendage(model, body_id)):
                continue
            # any other body hinged to the bus is a wheel: an axisymmetric rotor whose CoM is on
            # its axis, so its locked inertia is constant and its momentum Js Omega a
            wheel = model.body(body_id)
            if model.body_jntnum[body_id] != 1 or model.jnt_type[model.body_jntadr[body_id]] != mujoco.mjtJoint.mjJNT_HINGE:
                raise ValueError(f"{wheel.name} is on the bus but is neither a gimbal nor a wheel on one hinge")
            rot = quat_to_matrix(wheel.quat)
            axis = rot @ model.jnt_axis[model.body_jntadr[body_id]]
            com = wheel.pos + rot @ wheel.ipos
            principal = rot @ quat_to_matrix(wheel.iquat)
            inertia = principal @ np.diag(wheel.inertia) @ principal.T
            if _distance_to_line(com, wheel.pos + rot @ model.jnt_pos[model.body_jntadr[body_id]], axis) > 1e-9:
                raise ValueError(f"{wheel.name} CoM is off its spin axis")
            _check_axisymmetric(wheel.name, inertia, axis)
            inertias.append(inertia)
            masses.append(wheel.mass[0])
            coms.append(com)
            wheel_axes.append(axis)
            wheel_spin.append(axis @ inertia @ axis)
        for mass, com, inertia in locked_appendage_mass(model, bus_id):  # panels and slosh masses held at rest
            masses.append(mass)
            coms.append(com)
            inertias.append(inertia)
        masses, coms = np.array(masses, dtype=float), np.array(coms)
        system_com = masses @ coms / masses.sum()
        constant = sum(inertias)  # the bus's and the wheels' own: every CMG's turns with its gimbal
        for mass, com in zip(masses, coms):
            r = com - system_com
            constant += mass * (r @ r * np.eye(3) - np.outer(r, r))
        return cls(constant, cmg_inertia, geometry.gimbal_axes, geometry.spin_axes_zero,
                   geometry.spin_inertia, np.reshape(wheel_axes, (-1, 3)), np.array(wheel_spin))

    def rotations(self, beta):
        """R_i: rotation by beta_i about g_i, (4, 3, 3)."""
        return np.array([_rotation_about(g, b) for g, b in zip(self.gimbal_axes, beta)])

    def system_inertia(self, beta, rotations=None):
        """Locked inertia of the spacecraft about its CoM, bus axes [kg m^2]."""
        rot = self.rotations(beta) if rotations is None else rotations
        return self.constant_inertia + np.einsum("iab,ibc,idc->ad", rot, self.cmg_inertia, rot)

    def internal_momentum(self, beta, beta_rate, rotor_rate, rotations=None, wheel_rate=None):
        """Momentum of gimbals + rotors (+ wheels) relative to the bus, bus axes [N m s]:
        sum_i R_i K_i R_i^T g_i beta'_i + Js_i Omega_i R_i e_i (g_i is fixed by R_i), plus
        sum_j Jw_j Omega_j a_j of the wheels at speeds `wheel_rate` [rad/s] when the bus has them."""
        rot = self.rotations(beta) if rotations is None else rotations
        k_world = np.einsum("iab,ibc,idc->iad", rot, self.cmg_inertia, rot)
        gimbal_part = np.einsum("iab,ib,i->a", k_world, self.gimbal_axes, beta_rate)
        spin_axes = np.einsum("iab,ib->ia", rot, self.spin_axes_zero)
        momentum = gimbal_part + (self.spin_inertia * rotor_rate) @ spin_axes
        if wheel_rate is not None:
            momentum = momentum + (self.wheel_spin_inertia * wheel_rate) @ self.wheel_axes
        return momentum


def _check_axisymmetric(name, inertia, axis):
    """The reduced model ignores the rotor angle, which is exact only for a rotor whose
    inertia is symmetric about its spin axis: inertia = Jt 1 + (Js - Jt) a a^T."""
    js = axis @ inertia @ axis
    jt = (np.trace(inertia) - js) / 2.0
    expected = jt * np.eye(3) + (js - jt) * np.outer(axis, axis)
    if np.max(np.abs(inertia - expected)) > 1e-9 * np.max(np.abs(inertia)):
        raise ValueError(f"{name} inertia is not axisymmetric about its spin axis")


class GimbalHistory:
    """Interpolated beta(t), beta'(t), Omega(t) and the wheel speeds from samples (see module docstring)."""

    def __init__(self, t_samples, beta, beta_rate, rotor_rate, wheel_rate=None):
        t = np.asarray(t_samples, dtype=float)
        from scipy.interpolate import CubicHermiteSpline, CubicSpline, make_interp_spline  # on use: at the top it would cost every command start-up time
        self.beta = CubicHermiteSpline(t, np.asarray(beta, float), np.asarray(beta_rate, float))
        self.beta_rate = CubicSpline(t, np.asarray(beta_rate, dtype=float))
        self.rotor_rate = CubicSpline(t, np.asarray(rotor_rate, dtype=float))
        # piecewise linear: a wheel's motor torque is held over each control period, so its
        # absolute momentum is linear between the ticks and a spline through the kinks would ring
        self.wheel_rate = None if wheel_rate is None else make_interp_spline(t, np.asarray(wheel_rate, float), k=1)

    def __call__(self, t):
        return self.beta(t), self.beta_rate(t), self.rotor_rate(t)

    def wheels(self, t):
        """The wheel speeds at t [rad/s], None without wheels."""
        return None if self.wheel_rate is None else self.wheel_rate(t)


def _check_samples(t_samples, beta, beta_rate, rotor_rate):
    t = np.asarray(t_samples, dtype=float)
    for name, arr in (("beta", beta), ("beta_rate", beta_rate), ("rotor_rate", rotor_rate)):
        if np.ndim(arr) != 2 or np.shape(arr)[0] != t.size or np.shape(arr) != np.shape(beta):
            raise ValueError(f"{name} must have shape ({t.size}, units) like beta, got {np.shape(arr)}")
    if t.ndim != 1 or t.size < 4 or np.any(np.diff(t) <= 0):
        raise ValueError("t_samples must be at least 4 strictly increasing times")


def reduced_cmg_omega(mass_model, t_samples, beta, beta_rate, rotor_rate, omega0, t_eval,
                      rtol=1e-12, atol=1e-14):
    """Bus body rate w(t_eval) [rad/s], (N, 3), from the exact reduced model (module
    docstring): L_b' = -w x L_b, w = I_sys(beta)^-1 (L_b - H_int), integrated with DOP853
    from w(t_samples[0]) = omega0. `mass_model`: CmgMassModel or a compiled MjModel.
    beta, beta_rate, rotor_rate: (len(t_samples), 4) histories from the truth."""
    return reduced_cmg_segment(mass_model, t_samples, beta, beta_rate, rotor_rate, t_eval, omega0=omega0,
                               t_start=t_samples[0], rtol=rtol, atol=atol)[0]


def reduced_cmg_segment(mass_model, t_samples, beta, beta_rate, rotor_rate, t_eval, omega0=None,
                        momentum0=None, t_start=None, rtol=1e-12, atol=1e-14, wheel_rate=None):
    """(w(t_eval) (N, 3) [rad/s], L_b(t_eval[-1]) [N m s]): the reduced model (module docstring)
    integrated over [t_start, t_eval[-1]] (t_start: t_eval[0] unless given) from the bus-frame
    momentum `momentum0` at t_start, or from the body rate `omega0` there. The histories cover
    t_samples, which contains t_eval; `wheel_rate` (len(t_samples), m) the speeds of a hybrid
    bus's wheels, whose momentum joins H_int."""
    if isinstance(mass_model, mujoco.MjModel):
        mass_model = CmgMassModel.from_model(mass_model)
    _check_samples(t_samples, beta, beta_rate, rotor_rate)
    history = GimbalHistory(t_samples, beta, beta_rate, rotor_rate, wheel_rate)

    def body_rate(t, momentum_body):
        b, b_rate, rotor = history(t)
        rot = mass_model.rotations(b)
        inertia = mass_model.system_inertia(b, rot)
        internal = mass_model.internal_momentum(b, b_rate, rotor, rot, history.wheels(t))
        return np.linalg.solve(inertia, momentum_body - internal)

    def rhs(t, momentum_body):
        return -np.cross(body_rate(t, momentum_body), momentum_body)

    t_eval = np.asarray(t_eval, dtype=float)
    t0 = float(t_eval[0] if t_start is None else t_start)
    if momentum0 is None:
        b, b_rate, rotor = history(t0)
        momentum0 = (mass_model.system_inertia(b) @ np.asarray(omega0, dtype=float)
                     + mass_model.internal_momentum(b, b_rate, rotor, wheel_rate=history.wheels(t0)))
    from scipy.integrate import solve_ivp  # on use: at the top it would cost every command start-up time
    sol = solve_ivp(rhs, (t0, float(t_eval[-1])), momentum0, method="DOP853", t_eval=t_eval,
                    rtol=rtol, atol=atol)
    if not sol.success:
        raise RuntimeError(f"reduced CMG model integration failed: {sol.message}")
    omega = np.array([body_rate(t, m) for t, m in zip(sol.t, sol.y.T)])
    # scipy's solver object refers to itself through its wrapped right-hand side, so it and
    # everything `rhs` reaches stay in memory until the next full garbage collection: without
    # this, a long run's windows pile up their splines (~3.5 MB each) between collections
    history = None  # noqa: F841 (the closures' cell)
    return omega, sol.y[:, -1].copy()


def textbook_cmg_omega(inertia, geometry, t_samples, beta, beta_rate, omega0, t_eval,
                       rtol=1e-12, atol=1e-14):
    """Body rate from the textbook form of SEEDS §004: I w' + w x (I w + H) = -H', with a
    constant inertia I (3, 3), H = h sum_i a_i(beta) and H' = h J(beta) beta' (nominal rotor
    momentum, gimbal momentum ignored). For comparison only; (N, 3)."""
    t_samples = np.asarray(t_samples, dtype=float)
    from scipy.interpolate import CubicHermiteSpline, CubicSpline
    beta_spline = CubicHermiteSpline(t_samples, np.asarray(beta, float),
                                     np.asarray(beta_rate, float))
    rate_spline = CubicSpline(t_samples, np.asarray(beta_rate, dtype=float))
    inertia = np.asarray(inertia, dtype=float)

    def rhs(t, omega):
        b = beta_spline(t)
        momentum = geometry.momentum(b)
        momentum_rate = geometry.jacobian(b) @ rate_spline(t)
        return np.linalg.solve(inertia, -momentum_rate - np.cross(omega, inertia @ omega
                                                                  + momentum))

    t_eval = np.asarray(t_eval, dtype=float)
    from scipy.integrate import solve_ivp
    sol = solve_ivp(rhs, (t_samples[0], t_eval[-1]), np.asarray(omega0, dtype=float),
                    method="DOP853", t_eval=t_eval, rtol=rtol, atol=atol)
    if not sol.success:
        raise RuntimeError(f"textbook CMG model integration failed: {sol.message}")
    return sol.y.T


@dataclass(kw_only=True)
class ReducedCmgParams:
    # 1e-9 puts the integrator's own error near 1e-9 rad/s, far inside the usual 1e-6 bound;
    # tighter tolerances cost 20x more because each control tick's servo transient is resolved.
    rtol: float = param(1e-9, gt=0, lt=1e-3)


@reference("reduced_cmg", systems=CLUSTER_SYSTEMS, params=ReducedCmgParams)
def _reduced_cmg(plant, params):
    """Reduced CMG model L_b' = -w x L_b, w = I_sys(b)^-1 (L_b - H_int) from the recorded
    gimbal and rotor histories (`reduced_cmg_omega`)."""
    mass_model, omega0 = CmgMassModel.from_model(plant.model), plant.omega()
    inputs = ("truth/gimbal_angle", "truth/gimbal_rate", "truth/rotor_rate")
    wheels = ("truth/wheel_rate",) if mass_model.has_wheels else ()

    def segment(times, histories, lo, hi, momentum):
        # from w(0) = omega0 in the first window, then from the momentum the last one ended with
        return reduced_cmg_segment(mass_model, times, *(histories[key] for key in inputs), times[lo:hi + 1],
                                   omega0=omega0 if momentum is None else None, momentum0=momentum,
                                   rtol=params.rtol, atol=1e-14,
                                   wheel_rate=histories[wheels[0]] if wheels else None)

    return WindowedReference(segment, inputs + wheels, state=None)
