"""Attitude tracking law: program torque plus quaternion PD feedback on the tracking error.

SEEDS §004 stage 1 gives the open-loop program torque M* (eq. 9); open loop it lands on
the target only if the model is exact and the start state is the program's. This law
closes the loop around the program Λ*(t), ω*(t), ω*'(t):

    δq = Λ*~ ∘ q                      attitude error (actual body frame seen from the program's)
    ω_d = R(δq)ᵀ ω*,  δω = ω - ω_d    program rate in the actual body frame, rate error
    M = I (R(δq)ᵀ ω*' - δω × ω_d) + ω × I ω - Kp sign(δq_w) vec(δq) - Kd δω

with Kp = 2 ωn² I and Kd = 2 ζ ωn I. Since δq' = δq ∘ δω / 2 and (R(δq)ᵀ)' = -[δω×] R(δq)ᵀ,
the rigid body I ω' + ω × I ω = M (eq. 2) then obeys exactly

    δω' = -2 ωn² sign(δq_w) vec(δq) - 2 ζ ωn δω,

which for a small error angle δθ = 2 vec(δq) is δθ'' + 2 ζ ωn δθ' + ωn² δθ = 0: the
factor 2 in Kp makes ωn the true natural frequency. sign(δq_w) turns the body the short way.
With zero error the law reduces to the program torque M* of eq. (9).

Pure numpy, independent of MuJoCo: call it with the estimated state.
"""

from __future__ import annotations

import numpy as np

from testbed.errors import InputError
from testbed.math.cross import cross3
from testbed.math.validation import UNIT_TOLERANCE, finite_number, inertia_matrix, unit_quaternion, vector3
from testbed.math.quaternion import length, quat_conj, quat_mul, quat_rotate


class TrackingLaw:
    """Body torque that makes the rigid body follow `program`.

    `program` is anything with `state(t) -> (Λ*, ω*, ω*')`, e.g. a ProgramTrajectory.
    """

    def __init__(self, program, inertia, natural_frequency, damping_ratio):
        self.program = program
        self.inertia = inertia_matrix("body.inertia", inertia)
        wn = finite_number("control.natural_frequency_rad_s", natural_frequency)
        zeta = finite_number("control.damping_ratio", damping_ratio)
        if wn <= 0:
            raise InputError("control.natural_frequency_rad_s", f"must be > 0, got {wn:g}")
        if zeta < 0:
            raise InputError("control.damping_ratio", f"must be >= 0, got {zeta:g}")
        self.natural_frequency = wn
        self.damping_ratio = zeta
        self.kp = 2.0 * wn**2 * self.inertia  # 2: vec(δq) is half the error angle
        self.kd = 2.0 * zeta * wn * self.inertia

    def errors(self, t, q, w):
        """(δq, δω, ω_d): attitude error Λ*~∘q, rate error ω - ω_d, program rate ω_d in the body frame."""
        return self._errors(t, q, w)[:3]

    def _checked(self, q, w):
        """(q, w) checked: q normalised (estimated attitudes drift off |q| = 1 a little), only
        nonsense refused."""
        return unit_quaternion("state.q", q), vector3("state.w_rad_s", w)

    def _errors(self, t, q, w):
        q, w = self._checked(q, w)
        q_p, w_p, dw_p = self.program.state(t)
        dq = quat_mul(quat_conj(q_p), q)
        # R(δq)ᵀ applied to the program rate and acceleration in one broadcast call
        w_d, acc_p = quat_rotate(quat_conj(dq), np.stack([w_p, dw_p]))
        return dq, w - w_d, w_d, acc_p

    def feedback(self, t, q, w) -> np.ndarray:
        """PD part -Kp sign(δq_w) vec(δq) - Kd δω [N m]; zero on the program."""
        dq, dw, _, _ = self._errors(t, q, w)
        return self._pd(dq, dw)

    def _pd(self, dq, dw):
        sign = np.where(dq[..., :1] >= 0, 1.0, -1.0)  # the short way round: q and -q are one attitude
        return -np.matvec(self.kp, sign * dq[..., 1:]) - np.matvec(self.kd, dw)

    def __call__(self, t, q_est, w_est) -> np.ndarray:
        """Wanted body torque M [N m] for the estimated attitude q_est and body rate w_est."""
        return self.torque_and_errors(t, q_est, w_est)[0]

    def torque_and_errors(self, t, q_est, w_est):
        """(M, δq, δω): the wanted torque and the errors it acts on, from one program evaluation."""
        dq, dw, w_d, acc_p = self._errors(t, q_est, w_est)
        w = dw + w_d
        acc_d = acc_p - cross3(dw, w_d)
        return np.matvec(self.inertia, acc_d) + cross3(w, np.matvec(self.inertia, w)) + self._pd(dq, dw), dq, dw


class TrackingWorlds(TrackingLaw):
    """The tracking laws of many worlds as one, on (N, ...) rows: the laws' gains and inertias
    stacked, `program` the worlds' programs (anything with state(t) -> (N, ...) rows). Built from
    the worlds' own laws: nothing is checked again."""

    def __init__(self, laws: list, program):
        self.program = program
        for name in ("inertia", "kp", "kd"):
            setattr(self, name, np.array([getattr(law, name) for law in laws]))

    def keep(self, rows) -> None:
        for name in ("inertia", "kp", "kd"):
            setattr(self, name, getattr(self, name)[rows])

    def _checked(self, q, w):
        """The rows' q normalised; any row's nonsense (not finite, far from unit length) refused
        with ValueError, for the worlds' own laws to say which (testbed.batch.stacked_stages)."""
        norm = length(q)  # unit_quaternion's, row by row
        if not (np.all(np.abs(norm - 1.0) <= UNIT_TOLERANCE) and np.all(np.isfinite(w))):
            raise ValueError("an attitude estimate that a world's law refuses")
        return q / norm, w


