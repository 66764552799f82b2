"""Program (reference) rotation of the spacecraft between two attitude/rate states in time T.

SEEDS §004, stage 1 (Frolov & Uspenskii's "spherical" kinematic model, paper eq. 5-13):

    Λ*(t) = Λ_T ∘ Λ1(ψ1) ∘ Λ2(ψ2) ∘ Λ3(ψ3),   Λi = cos(ψi/2) + b_i sin(ψi/2)      (5), (6)
    ψi(t) = a0i + a1i t + a2i t² + a3i t³                                         (11), (13)
    ω* = 2 Λ*~ ∘ Λ*'   (7),   ω*' = 2 (Λ*~' ∘ Λ*' + Λ*~ ∘ Λ*'')   (8)
    M* = I ω*' + ω* × I ω*   (9)

The paper writes Λ* = Λ1∘Λ2∘Λ3 in a frame in which the final attitude is the identity;
here that frame is the target body frame, so the product is premultiplied by the target
quaternion Λ_T (a constant left factor leaves ω* = 2 Λ*~∘Λ*' unchanged). The axes b_i
are constant vectors of the target body frame, chosen as in eq. (10):

    b3 = ω_T/|ω_T|,   b2 ∝ (Λr0 ∘ b3 ∘ Λr0~) × b3,   Λr0 = Λ_T~ ∘ Λ0 (start seen from target).

With that b2, Λr0 = Λ2(ψ20) ∘ Λ3(ψ30) exactly, i.e. ψ10 = 0, and at t = T all ψi = 0 with
ψT' = (0, 0, |ω_T|): the boundary values (12). Departures from the OCR text, all checked
by tests/test_guidance.py:
- b1 = b2 × b3 (a right-handed triad; the OCR's b3 × b2 is left-handed and its printed
  half-angle formulas in (12) do not reproduce Λ0 with either handedness). The boundary
  values are computed from the decomposition itself, which is what (12) expresses.
- ω_T = 0 (rest at the end): b3 is free; we take the Euler (eigen) axis of Λr0. Then
  Λr0 = Λ3(ψ30), ψ20 = 0, and a rest-to-rest slew is the classic eigen-axis slew
  (ψ1 = ψ2 ≡ 0, ψ3 a cubic from the slew angle to 0).
- Λr0 is taken with a non-negative scalar part (the short way round); Λ*(0) may then be
  -Λ0, which is the same attitude.
Outside [0, T] every ψi continues at its boundary rate (ψi'' = 0): after T that is a
steady spin at ω_T about b3 (rest for ω_T = 0).

A rest-to-rest program may take another angle profile than the cubic, and an input shaper
(`profile`: testbed.guidance.rest_to_rest_profiles): ψ(t) = ψ0 (1 - g(t)) with g the profile's
fraction, which comes to rest at its own end (T plus the shaper's duration).

Pure numpy; quaternions (w, x, y, z), Hamilton product, body-to-world; rates in the body frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.errors import InputError
from testbed.guidance.rest_to_rest_profiles import RestToRestProfile
from testbed.math.validation import check_unit_vector, inertia_matrix, positive_number, unit_quaternion, vector3
from testbed.math.quaternion import quat_conj, quat_from_axis_angle, quat_mul, quat_rotate

# |(Λr0 b3 Λr0~) × b3| below this means b3 is (anti)parallel to its image: b2 is then free.
_PARALLEL_EPS = 1e-14
# |cos ψ20| below this: the start sits on the Cardan singularity ψ2 = ±90° of the model,
# where ω = E(ψ) ψ' cannot be solved for ψ' (eq. (12) divides by cos ψ20).
_LOCK_EPS = 1e-6
# Derivative orders (k1, k2, k3) of the factors Λ1, Λ2, Λ3 in the product rule for Λr, Λr', Λr''
# and the multinomial weights of the second derivative (2 for mixed first-order pairs).
_ORDERS = np.array([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1),
                    (2, 0, 0), (0, 2, 0), (0, 0, 2), (1, 1, 0), (1, 0, 1), (0, 1, 1)])
_SECOND_WEIGHTS = np.array([1.0, 1.0, 1.0, 2.0, 2.0, 2.0])


def _perpendicular(v):
    """A unit vector orthogonal to unit vector v (deterministic)."""
    helper = np.eye(3)[np.argmin(np.abs(v))]
    p = np.cross(v, helper)
    return p / np.linalg.norm(p)


def _rate_matrix(axes, psi):
    """E(ψ) with ω = E(ψ) ψ' for Λ = Λ1Λ2Λ3 (from eq. (7)): columns Λ3~Λ2~ b1 Λ2Λ3, Λ3~ b2 Λ3, b3."""
    b1, b2, b3 = axes
    l2c = quat_conj(quat_from_axis_angle(b2, psi[1]))
    l3c = quat_conj(quat_from_axis_angle(b3, psi[2]))
    c1 = quat_rotate(l3c, quat_rotate(l2c, b1))
    c2 = quat_rotate(l3c, b2)
    return np.column_stack([c1, c2, b3])


def cubic_coefficients(psi0, dpsi0, psiT, dpsiT, T):
    """(3, 4) coefficients a0..a3 of the cubics ψi(t) meeting ψ, ψ' at 0 and T (eq. 13)."""
    psi0, dpsi0, psiT, dpsiT = (np.asarray(x, dtype=float) for x in (psi0, dpsi0, psiT, dpsiT))
    a2 = (3.0 * (psiT - psi0) - T * (2.0 * dpsi0 + dpsiT)) / T**2
    a3 = (2.0 * (psi0 - psiT) + T * (dpsi0 + dpsiT)) / T**3
    return np.column_stack([psi0, dpsi0, a2, a3])


@dataclass(frozen=True)
class ProgramTrajectory:
    """Λ*(t) = q_ref ∘ Λ1∘Λ2∘Λ3 with constant axes (rows of `axes`) and cubic angles (`coeffs`).

    q_ref: target attitude Λ_T; axes: (3, 3) orthonormal b1, b2, b3 in the target body frame;
    coeffs: (3, 4) a0..a3 of ψ1..ψ3 (eq. 11); duration: T [s]; profile: for a rest-to-rest
    program, the angle profile that replaces the cubic (ψ = a0 (1 - g(t))), None for the cubic.
    Build it with `from_boundary` or `eigen_axis_slew`; the constructor only validates.
    """

    q_ref: np.ndarray
    axes: np.ndarray
    coeffs: np.ndarray
    duration: float
    profile: RestToRestProfile | None = None

    def __post_init__(self):
        object.__setattr__(self, "duration", positive_number("slew.duration_s", self.duration))
        object.__setattr__(self, "q_ref", unit_quaternion("slew.q_target", self.q_ref))
        axes = np.asarray(self.axes, dtype=float)
        if axes.shape != (3, 3) or not np.all(np.isfinite(axes)):
            raise InputError("slew.axes", "must be three finite 3-vectors b1, b2, b3")
        if np.abs(axes @ axes.T - np.eye(3)).max() > 1e-9:
            raise InputError("slew.axes", "b1, b2, b3 must be orthonormal (unit, mutually perpendicular)")
        object.__setattr__(self, "axes", axes)
        coeffs = np.asarray(self.coeffs, dtype=float)
        if coeffs.shape != (3, 4) or not np.all(np.isfinite(coeffs)):
            raise InputError("slew.coeffs", "must be a 3x4 array of finite cubic coefficients")
        object.__setattr__(self, "coeffs", coeffs)
        if self.profile is not None and np.any(coeffs[:, 1]):
            raise InputError("slew.profile", "a profile other than the cubic needs a rest-to-rest slew "
                             "(zero initial and final rates)")

    # ---- construction -------------------------------------------------------------------

    @classmethod
    def from_boundary(cls, q0, w0, qT, wT, T) -> "ProgramTrajectory":
        """Program from {ω0, Λ0} to {ωT, ΛT} in time T (eq. 3), axes by eq. (10), ψ by (12)-(13).

        q0, qT: unit quaternions (body to world); w0, wT: body rates [rad/s]; T [s].
        """
        T = positive_number("slew.duration_s", T)
        q0 = unit_quaternion("slew.q_initial", q0)
        qT = unit_quaternion("slew.q_target", qT)
        w0 = vector3("slew.w_initial_rad_s", w0)
        wT = vector3("slew.w_target_rad_s", wT)

        q_rel = quat_mul(quat_conj(qT), q0)  # Λr0: the start seen from the target frame
        if q_rel[0] < 0:  # same attitude, the short way round
            q_rel = -q_rel
        axes = _boundary_axes(q_rel, wT)
        psi0 = _decompose(q_rel, axes)
        E0 = _rate_matrix(axes, psi0)
        if np.any(w0) and abs(np.cos(psi0[1])) < _LOCK_EPS:
            raise InputError(
                "slew.w_initial_rad_s",
                "the start lies on the program's kinematic singularity (psi2 = ±90°: the final "
                "rate axis is turned by 90° between start and target), so a non-zero initial "
                "rate cannot be matched; change the end rate direction or start at rest",
            )
        dpsi0 = np.linalg.solve(E0, w0) if np.any(w0) else np.zeros(3)
        dpsiT = axes @ wT  # E(0) = [b1 b2 b3]: ψT' = (0, 0, |ωT|) by the choice of b3
        coeffs = cubic_coefficients(psi0, dpsi0, np.zeros(3), dpsiT, T)
        return cls(qT, axes, coeffs, T)

    @classmethod
    def eigen_axis_slew(cls, q0, axis, angle, T, profile: RestToRestProfile | None = None) -> "ProgramTrajectory":
        """Rest-to-rest slew by `angle` [rad, |angle| <= π] about the unit body `axis`, in time T,
        along the cubic or along `profile` (which then sets the duration)."""
        axis = check_unit_vector(axis, "slew.axis")
        angle = float(angle)
        if not np.isfinite(angle) or abs(angle) > np.pi:
            raise InputError("slew.angle_rad", f"must be finite with |angle| <= pi, got {angle!r}")
        q0 = unit_quaternion("slew.q_initial", q0)
        qT = quat_mul(q0, quat_from_axis_angle(axis / np.linalg.norm(axis), angle))
        cubic = cls.from_boundary(q0, np.zeros(3), qT, np.zeros(3), T)
        if profile is None:
            return cubic
        return cls(cubic.q_ref, cubic.axes, cubic.coeffs, profile.duration, profile)

    @property
    def end(self) -> float:
        """When the program comes to its final state [s]: T, or the shaped profile's end."""
        return self.duration if self.profile is None else self.profile.end

    # ---- evaluation ---------------------------------------------------------------------

    def angles(self, t):
        """ψ(t), ψ'(t), ψ''(t) as three (3,) arrays (eq. 11; linear outside [0, T]); with a
        profile, ψ0 (1 - g), -ψ0 g', -ψ0 g''."""
        if self.profile is not None:
            return profile_angles(self.coeffs, self.profile(float(t)))
        return cubic_angles(self.coeffs, self.duration, float(t))

    def _relative(self, t):
        """Λr = Λ1Λ2Λ3 and its first two time derivatives (product rule on eq. (6))."""
        return relative_rotation(self.axes, *self.angles(t))

    def state(self, t):
        """(Λ*(t), ω*(t), ω*'(t)) from one evaluation of eq. (5), (7), (8). The arrays of the last
        t asked for are kept (read-only): a slew law and its tracking law ask for the same t in
        every control tick."""
        kept = self.__dict__.get("_kept_state")
        if kept is not None and kept[0] == t:
            return kept[1]
        state = program_state(self.q_ref, *self._relative(t))
        for values in state:
            values.flags.writeable = False
        object.__setattr__(self, "_kept_state", (t, state))  # frozen fields; this is no field
        return state

    def attitude(self, t) -> np.ndarray:
        """Λ*(t), unit quaternion body to world (eq. 5 premultiplied by Λ_T)."""
        return quat_mul(self.q_ref, self._relative(t)[0])

    def rate(self, t) -> np.ndarray:
        """ω*(t) = 2 vec(Λ*~ ∘ Λ*') [rad/s, body frame] (eq. 7)."""
        return self.state(t)[1]

    def acceleration(self, t) -> np.ndarray:
        """ω*'(t) = 2 vec(Λ*~' ∘ Λ*' + Λ*~ ∘ Λ*'') [rad/s², body frame] (eq. 8)."""
        return self.state(t)[2]

    def torque(self, t, inertia) -> np.ndarray:
        """Program torque M* = I ω*' + ω* × I ω* [N m, body frame] (eq. 9)."""
        inertia = inertia_matrix("body.inertia", inertia)
        _, w, dw = self.state(t)
        return inertia @ dw + np.cross(w, inertia @ w)


class ProgramWorlds:
    """The programs of many worlds as one: `state(t)` gives (N, ...) rows of (Λ*, ω*, ω*') at
    the worlds' times t (N, 1), each row its world's `ProgramTrajectory.state`."""

    def __init__(self, programs: list):
        self.q_ref = np.array([p.q_ref for p in programs])
        self.axes = np.array([p.axes for p in programs])
        self.coeffs = np.array([p.coeffs for p in programs])
        self.duration = np.array([[p.duration] for p in programs])
        self.profiles = [p.profile for p in programs]
        self._kept = (None, None)

    def keep(self, rows) -> None:
        for name in ("q_ref", "axes", "coeffs", "duration"):
            setattr(self, name, getattr(self, name)[rows])
        self.profiles = [self.profiles[i] for i in rows]
        self._kept = (None, None)

    def state(self, t):
        """(Λ*, ω*, ω*') (N, 4), (N, 3), (N, 3) at the worlds' times t (N, 1) [s]; the last t
        asked for (the same array) is answered from the last evaluation."""
        if self._kept[0] is t:
            return self._kept[1]
        psi, dpsi, ddpsi = cubic_angles(self.coeffs, self.duration, t)
        for row, profile in enumerate(self.profiles):
            if profile is not None:
                psi[row], dpsi[row], ddpsi[row] = profile_angles(self.coeffs[row], profile(float(t[row, 0])))
        state = program_state(self.q_ref, *relative_rotation(self.axes, psi, dpsi, ddpsi))
        self._kept = (t, state)
        return state


def cubic_angles(coeffs, duration, t):
    """ψ, ψ', ψ'' (..., 3) of the cubics with coefficients `coeffs` (..., 3, 4) at t [s] (eq. 11),
    continued at their boundary rates outside [0, T] (ψ'' = 0); `duration` T and t numbers or
    (..., 1) columns (one per world of a batch)."""
    a = coeffs
    tc = np.minimum(np.maximum(t, 0.0), duration)
    psi = a[..., 0] + tc * (a[..., 1] + tc * (a[..., 2] + tc * a[..., 3]))
    dpsi = a[..., 1] + tc * (2.0 * a[..., 2] + 3.0 * tc * a[..., 3])
    ddpsi = 2.0 * a[..., 2] + 6.0 * tc * a[..., 3]
    outside = tc != t
    return psi + (t - tc) * dpsi, dpsi, np.where(outside, 0.0, ddpsi)


def profile_angles(coeffs, fraction):
    """ψ0 (1 - g), -ψ0 g', -ψ0 g'' of a rest-to-rest program (..., 3, 4) for the profile's
    (g, g', g'') at one time (RestToRestProfile.__call__)."""
    g, dg, ddg = fraction
    a0 = coeffs[..., 0]
    return a0 * (1.0 - g), -a0 * dg, -a0 * ddg


def relative_rotation(axes, psi, dpsi, ddpsi):
    """Λr = Λ1Λ2Λ3 and its first two time derivatives (product rule on eq. (6)) for the axes
    (..., 3, 3) (rows b1, b2, b3) and the angles ψ, ψ', ψ'' (..., 3)."""
    # D[k, i]: k-th time derivative of Λi.  Λi' = (ψi'/2) b_i ∘ Λi and
    # Λi'' = (ψi''/2) b_i ∘ Λi - (ψi'/2)² Λi   (b_i ∘ b_i = -1 for a unit vector).
    c, s = np.cos(psi / 2)[..., None], np.sin(psi / 2)[..., None]
    lam = np.concatenate([c, s * axes], axis=-1)
    b_lam = np.concatenate([-s, c * axes], axis=-1)  # b ∘ (c + s b) = -s + c b
    dpsi, ddpsi = dpsi[..., None], ddpsi[..., None]
    D = np.stack([lam, 0.5 * dpsi * b_lam, 0.5 * ddpsi * b_lam - 0.25 * (dpsi**2) * lam], axis=-3)
    # All ten products D[k1,0] D[k2,1] D[k3,2] with k1 + k2 + k3 <= 2 in one broadcast call.
    k = _ORDERS
    prods = quat_mul(quat_mul(D[..., k[:, 0], 0, :], D[..., k[:, 1], 1, :]), D[..., k[:, 2], 2, :])
    return prods[..., 0, :], prods[..., 1:4, :].sum(axis=-2), np.vecmat(_SECOND_WEIGHTS, prods[..., 4:, :])


def program_state(q_ref, lam, dlam, ddlam):
    """(Λ*, ω*, ω*') of eq. (5), (7), (8) from the target Λ_T and Λr, Λr', Λr'' (..., 4)."""
    # Rows: Λ~∘Λ' (7), Λ~'∘Λ' and Λ~∘Λ'' (8), Λ_T∘Λ (5): one broadcast product.
    q_ref = np.broadcast_to(q_ref, lam.shape)
    left = np.stack([quat_conj(lam), quat_conj(dlam), quat_conj(lam), q_ref], axis=-2)
    right = np.stack([dlam, dlam, ddlam, lam], axis=-2)
    p = quat_mul(left, right)
    return p[..., 3, :], 2.0 * p[..., 0, 1:], 2.0 * (p[..., 1, 1:] + p[..., 2, 1:])


def _boundary_axes(q_rel, wT):
    """Rows b1, b2, b3 of eq. (10) (b1 = b2 × b3; eigen axis for b3 when ωT = 0, see module doc)."""
    wn = np.linalg.norm(wT)
    if wn > 0:
        b3 = wT / wn
    else:
        vn = np.linalg.norm(q_rel[1:])
        b3 = q_rel[1:] / vn if vn > 0 else np.array([0.0, 0.0, 1.0])
    c = np.cross(quat_rotate(q_rel, b3), b3)
    cn = np.linalg.norm(c)
    # Parallel (e.g. the eigen-axis case) or antiparallel image: any b2 ⊥ b3 decomposes Λr0.
    b2 = c / cn if cn > _PARALLEL_EPS else _perpendicular(b3)
    b2 = b2 - (b2 @ b3) * b3  # remove rounding so the triad is orthonormal to 1e-16
    b2 /= np.linalg.norm(b2)
    return np.array([np.cross(b2, b3), b2, b3])


def _decompose(q_rel, axes):
    """(ψ10, ψ20, ψ30) with Λ1(0)∘Λ2(ψ20)∘Λ3(ψ30) = ±q_rel and b2 ⊥ b3, Λr0(b3) (eq. 12).

    ψ2 is the angle that turns b3 onto its image m = Λr0(b3) about b2; what remains,
    Λ2~ ∘ Λr0, fixes b3 and is Λ3(ψ30). Angles are reduced to [-π, π].
    """
    b1, b2, b3 = axes
    m = quat_rotate(q_rel, b3)
    # Rotating b3 about b2 by ψ moves it towards b2 × b3 = b1.
    psi2 = np.arctan2(m @ b1, m @ b3)
    rest = quat_mul(quat_conj(quat_from_axis_angle(b2, psi2)), q_rel)
    psi3 = 2.0 * np.arctan2(rest[1:] @ b3, rest[0])
    psi3 = (psi3 + np.pi) % (2.0 * np.pi) - np.pi  # flips the sign of Λ only
    return np.array([0.0, psi2, psi3])
