"""Geometry of a single-gimbal CMG cluster of any array, read back from a compiled model.

`ClusterGeometry` reads the axes, rotor momenta, H(beta) and dH/dbeta from the compiled model
(never typed in a second time); the units are the bodies and joints gimbal1, rotor1, ... (`unit_names`).
"""

import math

import mujoco
import numpy as np

from testbed.systems.free_bus import BUS_BODY
from testbed.math.quaternion import quat_to_matrix
from testbed.systems.cmg_cluster.momentum_gauge import envelope_gauge

# the systems whose plant is this folder's CmgPlant: the seed's rhombus and clusters of any array
CLUSTER_SYSTEMS = ("cmg_rhombus", "cmg_cluster")


def unit_names(units: int) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(gimbal names, rotor names) of a cluster of `units`: body and joint names gimbal1, rotor1, ..."""
    return (tuple(f"gimbal{i}" for i in range(1, units + 1)),
            tuple(f"rotor{i}" for i in range(1, units + 1)))


def unit_count(model) -> int:
    """How many units a compiled model holds: its gimbal joints gimbal1, gimbal2, ... in a row."""
    count = 0
    while mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, f"gimbal{count + 1}") >= 0:
        count += 1
    return count


ROTOR_SPEED_NUMERIC = "rotor_nominal_speed"


class ClusterGeometry:
    """CMG cluster geometry read from a compiled model, in the bus frame.

    gimbal_axes g_i, spin_axes_zero e_i (spin at beta = 0), turn_axes = g_i x e_i:
    (n, 3) unit vectors for n units. spin_inertia Js_i [kg m^2], nominal_rotor_speed Omega [rad/s],
    rotor_momentum h_i = Js_i Omega (n,), h: the reference momentum [N m s], the common value of
    h_i when they are equal, else the largest; `relative_momentum` h_i / h (None when equal), by
    which the columns of `unit_jacobian` are scaled, so that h J(b) b' = H' holds for any h_i.
    gimbal_axis_inertia J_g,i [kg m^2] (4,): gimbal frame and rotor about the gimbal axis (0,
    the spin momentum alone, until `with_gimbal_inertia` gives it). rotor_speed_range (min, max)
    [rad/s]: the speeds the rotor motors can hold, None for fixed-speed rotors.
    """

    rotor_speed_range: tuple[float, float] | None = None

    def __init__(self, gimbal_axes, spin_axes_zero, spin_inertia, nominal_rotor_speed):
        self.gimbal_axes = np.asarray(gimbal_axes, dtype=float)
        self.spin_axes_zero = np.asarray(spin_axes_zero, dtype=float)
        self.turn_axes = np.cross(self.gimbal_axes, self.spin_axes_zero)
        self.spin_inertia = np.asarray(spin_inertia, dtype=float)
        self.nominal_rotor_speed = float(nominal_rotor_speed)
        self.rotor_momentum = self.spin_inertia * self.nominal_rotor_speed
        if np.ptp(self.rotor_momentum) > 1e-12 * self.rotor_momentum.max():
            self.h = float(self.rotor_momentum.max())
            self.relative_momentum = self.rotor_momentum / self.h
        else:  # equal momenta: the columns are the unit ones, untouched
            self.h = float(self.rotor_momentum.mean())
            self.relative_momentum = None
        self.gimbal_axis_inertia = np.zeros(len(self.gimbal_axes))
        # turned_axes_floats' last angles and axes, and turned_axes' arrays of them once asked for
        self._turned_key, self._turned_floats, self._turned = None, None, None
        self._spin_zero_floats, self._turn_floats = self.spin_axes_zero.tolist(), self.turn_axes.tolist()

    def with_gimbal_inertia(self, cmg_inertia) -> "ClusterGeometry":
        """This geometry, told the inertia K_i of each gimbal frame with its rotor about their
        CoMs at beta = 0, bus frame (4, 3, 3) (CmgMassModel.cmg_inertia, read from the compiled
        model): keeps J_g,i = g_i' K_i g_i. The gimbal axis must be a principal axis of K_i (true
        of the rhombus: the gimbal frame's inertia is principal about it and the rotor is
        symmetric about its spin axis, normal to it), so K_i g_i = J_g,i g_i at every angle."""
        turning = np.einsum("iab,ib->ia", np.asarray(cmg_inertia, float), self.gimbal_axes)
        along = np.einsum("ia,ia->i", turning, self.gimbal_axes)
        if np.abs(turning - along[:, None] * self.gimbal_axes).max() > 1e-9 * along.max():
            raise ValueError("a gimbal axis is not a principal axis of its gimbal and rotor")
        self.gimbal_axis_inertia = along
        return self

    @classmethod
    def from_model(cls, model):
        """Axes from body quaternions and joint axes, Js from the rotor inertials (the inertia
        about the spin axis), Omega from the custom numeric "rotor_nominal_speed"."""
        bus_id = model.body(BUS_BODY).id
        gimbal_axes, spin_axes, spin_inertia = [], [], []
        for gimbal_name, rotor_name in zip(*unit_names(unit_count(model))):
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

    def turned_axes(self, beta):
        """(cos b_i e_i + sin b_i s_i z, -sin b_i e_i + cos b_i s_i z), (..., 4, 3) each: the unit
        spin axes and their derivatives along beta_i (the unit Jacobian's columns, as rows). For
        one set of angles (4,) they are those of `turned_axes_floats` (one cos and sin a gimbal,
        kept for the last angles), handed out as they are, read-only: the steering stage and the
        gimbal servo ask for the same angles in every control tick."""
        beta = np.asarray(beta, dtype=float)
        if beta.ndim != 1:  # a history: broadcast
            angle = beta[..., None]
            c, s = np.cos(angle), np.sin(angle)
            return c * self.spin_axes_zero + s * self.turn_axes, -s * self.spin_axes_zero + c * self.turn_axes
        floats = self.turned_axes_floats(beta)
        if self._turned is None:
            self._turned = tuple(np.array(rows) for rows in floats)
            for axes in self._turned:
                axes.flags.writeable = False
        return self._turned

    def turned_axes_floats(self, beta) -> tuple[list, list]:
        """`turned_axes` at one set of angles beta (4,) [rad] as plain floats, (spin axes, Jacobian
        columns), 4 lists of 3 each, kept for the last angles asked for (not to be modified): the
        sums and products numpy's broadcast would do, on math.cos and math.sin, for a caller that
        works on floats (the gimbal servo's tick)."""
        beta = np.asarray(beta, dtype=float)
        key = beta.tobytes()
        if key != self._turned_key:
            spin, columns = [], []
            for b, (e0, e1, e2), (t0, t1, t2) in zip(beta.tolist(), self._spin_zero_floats, self._turn_floats):
                c, s = math.cos(b), math.sin(b)
                spin.append([c * e0 + s * t0, c * e1 + s * t1, c * e2 + s * t2])
                columns.append([-s * e0 + c * t0, -s * e1 + c * t1, -s * e2 + c * t2])
            self._turned_key, self._turned_floats, self._turned = key, (spin, columns), None
        return self._turned_floats

    def spin_axes(self, beta):
        """Unit spin axes at gimbal angles beta, (..., 4, 3): cos b_i e_i + sin b_i s_i z."""
        return self.turned_axes(beta)[0].copy()

    def momentum(self, beta, rotor_rates=None):
        """Total rotor spin momentum H(beta) = sum_i h_i (cos b_i e_i + sin b_i s_i z) in the
        bus frame [N m s] (SEEDS §004 eq. (15)); with rotor_rates, h_i = Js_i Omega_i.
        Leading dimensions of beta and rotor_rates (e.g. a recorded history) broadcast."""
        h = self.rotor_momentum if rotor_rates is None else (
            self.spin_inertia * np.asarray(rotor_rates, dtype=float))
        return (h[..., None, :] @ self.turned_axes(beta)[0])[..., 0, :]

    def held_momentum(self, beta, rotor_rates, gimbal_rates):
        """The momentum the cluster holds relative to the bus in full [N m s], bus frame: the
        rotors' spin H(beta, Omega) (`momentum`, SEEDS §004 eq. (15)) plus each gimbal frame and
        rotor turning with its gimbal, J_g,i b'_i g_i (`with_gimbal_inertia`; the gimbal-rate
        terms of CmgMassModel.internal_momentum). With the gimbal rates from the tachometers it
        is the momentum MuJoCo's mass matrix gives (CmgRhombus.internal_momentum_body)."""
        return self.momentum(beta, rotor_rates) + self.turning_momentum(gimbal_rates)

    def turning_momentum(self, gimbal_rates):
        """sum_i J_g,i b'_i g_i [N m s], bus frame: what the gimbal frames and rotors turning with
        their gimbals add to the spin momentum (`held_momentum`)."""
        return (self.gimbal_axis_inertia * np.asarray(gimbal_rates, dtype=float)) @ self.gimbal_axes

    def unit_jacobian(self, beta):
        """dH/dbeta divided by the reference momentum h, (..., 3, n): column i = (h_i / h)
        (-sin b_i e_i + cos b_i s_i z) (SEEDS §004 eq. (18) divided by h; h_i / h = 1 for equal
        rotors). Steering solves h J(b) b' = H' (eq. (17)). Leading dimensions of beta (a
        recorded history) broadcast."""
        columns = np.swapaxes(self.turned_axes(beta)[1].copy(), -1, -2)
        return columns if self.relative_momentum is None else columns * self.relative_momentum

    def unit_jacobian_derivative(self, beta):
        """dJ_i/dbeta_i of the unit Jacobian, (3, n): column i = -(h_i / h) (cos b_i e_i + sin b_i
        s_i z), the negative spin axis (eq. (18) differentiated; column i of J depends on b_i only)."""
        derivative = -self.spin_axes(beta).T
        return derivative if self.relative_momentum is None else derivative * self.relative_momentum

    def jacobian(self, beta):
        """dH/dbeta at the nominal rotor momenta [N m s / rad], (3, n): h_i times unit column."""
        if self.relative_momentum is None:
            return self.unit_jacobian(beta) * self.rotor_momentum
        return self.unit_jacobian(beta) * self.h

    def singularity_measure(self, beta):
        """sqrt(det(J J^T)) of the unit Jacobian: 0 at a singular set, up to (n/3)^(3/2) for n equal
        rotors. A float for one set of angles (n,), an array for a history (..., n)."""
        j = self.unit_jacobian(beta)
        measure = np.sqrt(np.maximum(np.linalg.det(j @ np.swapaxes(j, -1, -2)), 0.0))
        return float(measure) if measure.ndim == 0 else measure

    def momentum_gauge(self, momenta):
        """(gauge, u) of momenta P (m, 3) [N m s], body axes: max_u u·P / S(u) with S(u) the most
        momentum the cluster holds along u (gauge <= 1: P can be held; for this layout exactly,
        momentum_gauge.py), and the direction u of the maximum (m, 3). The torques the cluster
        gives at gimbal rates up to beta'max are beta'max times the same set, so the gauge of a
        torque T [N m] is the least rate limit [rad/s] at which some gimbal state gives it. The neutral
        interface through which a stage asks what the actuators can hold (docs/theory/lebedev.md "Non-zero total
        momentum")."""
        return envelope_gauge(momenta, self.gimbal_axes, self.rotor_momentum)
