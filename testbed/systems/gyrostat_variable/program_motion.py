"""Lagrange dynamics of the variable-structure gyrostat in the Euler angles q = (phi, psi, theta),
computed with MuJoCo (Bezglasny & Khudyakova, seed 002, eqs. 2.2, 3.1, 3.3, 3.4).

MuJoCo's generalised velocity of the carrier is its body rate w = E(q) q' (the paper's
kinematic equations before (2.2), `testbed.math.euler_angles.body_rates`), so the Euler-angle
generalised force conjugate to q is Q = E^T tau for a body torque tau, and

    A(t, q) = E^T M_ww E,       M_ww = the carrier's rotational block of mj_fullM,

the paper's A(t, q) of (2.2): the hinges of the rod and rotor are prescribed (rheonomic), so
they enter only through t. The inverse dynamics "A q'' + (everything else in 2.2)" at any
(t, q, q', q'') is E^T (rotational rows of mj_inverse) with w' = E q'' + E' q' and the
hinges at their angles, rates and prescribed accelerations. Evaluated along the program r(t)
this is the program force (3.1).

Stabilisation (3.4): with V = 1/2 x'^T A x' + 1/2 x^T C x (3.3), x = q - r(t), the control

    Q = [A(t, q) r'' + h(t, q, q')] - 1/2 A' x' - C x - D x'

(h: every velocity and time term of 2.2, i.e. inverse dynamics at the actual state with the
program acceleration) gives the closed loop A x'' + (1/2 A' + D) x' + C x = 0 and
V' = -x'^T D x' <= 0, the paper's semidefinite derivative; the paper's (3.4) is the same
control written out term by term. Q_s = Q - Q_p is recorded as the stabilising force.
"""

from __future__ import annotations

import mujoco
import numpy as np

from testbed.math.euler_angles import body_rates, quat_from_euler, rate_matrix, rate_matrix_dot_times


class EulerDynamics:
    """Inverse dynamics and the mass matrix A(t, q) of a compiled gyrostat_variable model, on a
    private MjData (never the truth's)."""

    def __init__(self, model: mujoco.MjModel):
        self.model = model
        self.data = mujoco.MjData(model)
        free = model.joint("bus")
        self._qpos, self._dof = int(free.qposadr[0]), int(free.dofadr[0])
        self._hinge_qpos = [int(model.joint(f"{n}_hinge").qposadr[0]) for n in ("rod", "rotor")]
        self._hinge_dof = [int(model.joint(f"{n}_hinge").dofadr[0]) for n in ("rod", "rotor")]
        self._full = np.zeros((model.nv, model.nv))

    def _set(self, q, qd, hinge_angles, hinge_rates) -> None:
        d = self.data
        d.qpos[:] = 0.0
        d.qpos[self._qpos + 3:self._qpos + 7] = quat_from_euler(q)
        d.qpos[self._hinge_qpos] = hinge_angles
        d.qvel[:] = 0.0
        d.qvel[self._dof + 3:self._dof + 6] = body_rates(q, qd)
        d.qvel[self._hinge_dof] = hinge_rates

    def inverse(self, q, qd, qdd, hinge_angles, hinge_rates, hinge_accels=(0.0, 0.0)) -> np.ndarray:
        """Body torque [N m, carrier axes] that gives Euler accelerations q'' at (q, q') with the
        hinges at the given angles, rates and accelerations (mj_inverse, eq. 2.2 solved for Q)."""
        self._set(q, qd, hinge_angles, hinge_rates)
        d = self.data
        d.qacc[:] = 0.0
        d.qacc[self._dof + 3:self._dof + 6] = rate_matrix(q) @ np.asarray(qdd, float) + rate_matrix_dot_times(q, qd)
        d.qacc[self._hinge_dof] = hinge_accels
        mujoco.mj_inverse(self.model, d)
        return d.qfrc_inverse[self._dof + 3:self._dof + 6].copy()

    def mass_matrix(self, q, hinge_angles) -> np.ndarray:
        """A(t, q) = E^T M_ww E: the Euler-angle mass matrix of (2.2) (kinetic energy 1/2 q'^T A q')."""
        self._set(q, np.zeros(3), hinge_angles, np.zeros(2))
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_comPos(self.model, self.data)
        mujoco.mj_crb(self.model, self.data)
        mujoco.mj_fullM(self.model, self.data, self._full)
        a = self._dof + 3
        E = rate_matrix(q)
        return E.T @ self._full[a:a + 3, a:a + 3] @ E

    def mass_matrix_rate(self, q, qd, hinge_angles, hinge_rates, h: float = 1e-4) -> np.ndarray:
        """A' = dA/dt along the motion (q', alpha', sigma'), by a central difference in time."""
        q, qd = np.asarray(q, float), np.asarray(qd, float)
        ha, hr = np.asarray(hinge_angles, float), np.asarray(hinge_rates, float)
        return (self.mass_matrix(q + h * qd, ha + h * hr) - self.mass_matrix(q - h * qd, ha - h * hr)) / (2 * h)

    def generalised_force(self, q, torque) -> np.ndarray:
        """Q = E(q)^T tau: the Euler-angle generalised force of a body torque."""
        return rate_matrix(q).T @ np.asarray(torque, float)

    def body_torque(self, q, force) -> np.ndarray:
        """tau = E(q)^-T Q (E is singular only at the gimbal lock sin theta = 0)."""
        return np.linalg.solve(rate_matrix(q).T, np.asarray(force, float))
