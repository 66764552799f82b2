"""Closed-form body-frame angular velocity of a torque-free rigid body.

Euler's equations with no torque, principal axes, ``I_i w_i' = (I_j - I_k) w_j w_k``
(i, j, k cyclic), are solved by Jacobi elliptic functions (Landau & Lifshitz, Mechanics,
§37; Whittaker, Analytical Dynamics, §69).  With the principal axes relabelled
``a, b, c`` so that ``c`` is the axis the polhode encircles, ``b`` the intermediate axis
and ``a`` the remaining extreme axis,

    w_a = alpha cn(u | m),   w_b = beta sn(u | m),   w_c = sigma_c gamma dn(u | m),
    u = s nu t + u0,

    X = |L^2 - 2T I_c|,  Y = |L^2 - 2T I_a|,  S = L^2 - 2T I_b,
    alpha^2 = X / (I_a |I_c - I_a|),  beta^2 = X / (I_b |I_c - I_b|),
    gamma^2 = Y / (I_c |I_c - I_a|),  nu^2 = |I_c - I_b| Y / (I_a I_b I_c),
    m = |I_b - I_a| X / (|I_c - I_b| Y),  1 - m = |I_c - I_a| |S| / (|I_c - I_b| Y).

``c`` is the major axis when ``S > 0`` (L^2 > 2T I_mid) and the minor axis when ``S < 0``.
On the separatrix (m = 1) cn = dn = sech and sn = tanh.  Axisymmetric bodies are the
case m = 0 (cn = cos, sn = sin, dn = 1: harmonic precession).

The sense of rotation ``s`` follows from substituting the solution into Euler's
equations written in the relabelled frame: if ``(a, b, c)`` is an odd permutation of
``(1, 2, 3)`` the relabelled frame is left-handed, which reverses the sign of the
gyroscopic term, so ``s = parity(a, b, c) * sign(w_c) * sign(I_c - I_b)``.

Numerical notes (why the code does not just call ``scipy.special.ellipj``):
- X, Y and S are the sums ``sum_i I_i (I_i - I_ref) w_i^2``, evaluated exactly
  (``fractions.Fraction`` on the float data) and rounded once: as differences of L^2 and
  2T they cancel catastrophically near a pure spin and near the separatrix, where the
  relative error of 1 - m would be eps / (1 - m).
- Near the separatrix the parameter m is within a few ulp of 1; ``ellipj(u, m)`` only
  takes m, whose rounding error (1e-16 absolute) then dominates.  Here the complementary
  parameter m1 = 1 - m is carried exactly: the argument is reduced with K from
  ``ellipkm1(m1)``, quarter-period identities keep the AGM argument in [0, K/2], the AGM
  starts from sqrt(m1), dn is sqrt(cn^2 + m1 sn^2), and the initial phase is an
  incomplete integral F(phi | m) = sin(phi) R_F(cos^2 phi, cos^2 phi + m1 sin^2 phi, 1)
  (Carlson, DLMF 19.25.5), all functions of m1 rather than m.
- The separatrix formula is used only when S is zero to within the rounding of the data
  (``|S| <= SEPARATRIX_RTOL * (I_a |I_b - I_a| w_a^2 + I_c |I_c - I_b| w_c^2)``, 8 ulp):
  a one-ulp change of w0 could then put the body in either regime.  Anywhere else the exact
  elliptic (periodic) form is used, however small 1 - m is.  The separatrix form is the
  m1 -> 0 limit: for data a rounding error off the separatrix the true motion leaves the
  intermediate axis after |u| ~ (1/2) ln(16 / m1) ~ 20, the formula never does.

Accuracy (measured): against a 40-digit mpmath evaluation of the same formulas, <= 2.5e-14
of |w0| over 100-1000 s on random bodies and 2e-13 down to 1 - m = 3e-15; against DOP853
(rtol 1e-12) the differences are the integrator's (they shrink with its rtol): 1.7e-12
(Skylab, Lebedev's w0), 1.0e-12 (Skylab, fast tumble) over 1000 s.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np
from scipy.special import elliprf, ellipkm1

from testbed.errors import InputError
from testbed.math.validation import vector3

# |S| below this fraction of the two terms it is the difference of: within the data's
# rounding, so the separatrix (sech/tanh) form is used.
SEPARATRIX_RTOL = 8.0 * np.finfo(float).eps


@dataclass(frozen=True)
class TorqueFreeSolution:
    """The closed-form solution for one (inertia, omega0); call ``omega(t)`` to evaluate.

    regime: "equilibrium" (constant w: pure principal-axis spin, sphere, or w = 0),
        "major" (polhode around the major axis, L^2 > 2T I_mid), "minor" (around the
        minor axis, L^2 < 2T I_mid) or "separatrix" (L^2 = 2T I_mid).
    axes: indices (a, b, c) into the caller's axis order: cn axis, sn axis, dn axis.
    amplitudes: (alpha, beta, gamma), rad/s; on the separatrix alpha carries sign(w_a).
    sign_c: sign of w_c (the dn axis never changes sign).
    m, m1: elliptic parameter and 1 - m (m = 0 for an axisymmetric body).
    nu: rate of the elliptic argument u, rad/s.  period: period of w(t), s (4K/nu; inf on
        the separatrix and for an equilibrium).
    sense: +1 or -1, u = sense * nu * t + u0.
    energy, momentum: T = (1/2) w.I w (J) and |L| = |I w| (N m s), both constant.
    """

    regime: str
    inertia: tuple[float, float, float]
    omega0: tuple[float, float, float]
    axes: tuple[int, int, int]
    amplitudes: tuple[float, float, float]
    sign_c: float
    sense: float
    m: float
    m1: float
    nu: float
    u0: float
    period: float
    energy: float
    momentum: float

    def omega(self, t) -> np.ndarray:
        """Body-frame angular velocity at times t (s); returns shape (len(t), 3), rad/s."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.empty((t.size, 3))
        if self.regime == "equilibrium":
            out[:] = self.omega0
            return out
        a, b, c = self.axes
        alpha, beta, gamma = self.amplitudes
        u = self.sense * self.nu * t + self.u0
        if self.regime == "separatrix":
            sech = 1.0 / np.cosh(u)
            # sign_a is folded into alpha for the separatrix (w_a never changes sign).
            out[:, a] = alpha * sech
            out[:, b] = beta * np.tanh(u)
            out[:, c] = self.sign_c * gamma * sech
            return out
        sn, cn, dn = jacobi_sncndn(u, self.m1)
        out[:, a] = alpha * cn
        out[:, b] = beta * sn
        out[:, c] = self.sign_c * gamma * dn
        return out


def jacobi_sncndn(u, m1: float):
    """Jacobi sn, cn, dn(u | m) for 0 <= m <= 1 given the complementary parameter m1 = 1 - m.

    Descending Landen / arithmetic-geometric mean (Abramowitz & Stegun 16.4; the algorithm
    of Cephes ``ellpj``), after reducing u to [-K, K] with sn(u + 2K) = -sn u,
    cn(u + 2K) = -cn u, dn(u + 2K) = dn u, and to [0, K/2] with A&S 16.8
    (sn(K - v) = cd v, cn(K - v) = k' sd v, dn(K - v) = k' nd v).  The AGM starts from
    b0 = sqrt(m1) and dn = sqrt(cn^2 + m1 sn^2), so 1 - m is never formed by cancellation.
    Measured against 50-digit mpmath for |u| <= 6K: 4e-16 for m1 >= 1e-3, 3e-13 at
    m1 = 1e-15, 2e-12 at 1e-20 (where scipy's ellipj, which takes m, is off by O(1) from
    m1 ~ 1e-12).  Below ~1e-20 cn near u = K (~ m1^(1/4)) loses relative precision.
    """
    u = np.asarray(u, dtype=float)
    m1 = float(m1)
    if not 0.0 <= m1 <= 1.0:
        raise InputError("m1", f"complementary parameter must be in [0, 1], got {m1}")
    m = 1.0 - m1
    if m1 == 0.0:  # separatrix limit
        sech = 1.0 / np.cosh(u)
        return np.tanh(u), sech, sech.copy()
    kk = float(ellipkm1(m1))  # K(m), computed from m1
    kp = np.sqrt(m1)  # k'
    n = np.rint(u / (2.0 * kk))
    r = u - 2.0 * kk * n
    half_sign = np.where(np.mod(n, 2.0) == 0.0, 1.0, -1.0)
    w = np.abs(r)
    big = w > 0.5 * kk
    v = np.where(big, kk - w, w)
    sn_v, cn_v, dn_v = _agm_sncndn(v, m, m1)
    sn_w = np.where(big, cn_v / dn_v, sn_v)
    cn_w = np.where(big, kp * sn_v / dn_v, cn_v)
    dn_w = np.where(big, kp / dn_v, dn_v)
    sn = np.sign(r) * sn_w * half_sign
    cn = cn_w * half_sign
    return sn, cn, dn_w


def _agm_sncndn(v, m: float, m1: float):
    """sn, cn, dn by the AGM/Landen descent (Cephes ellpj) for |v| <= K/2."""
    a = [1.0]
    c = [np.sqrt(m)]
    b = np.sqrt(m1)
    eps = np.finfo(float).eps
    while abs(c[-1] / a[-1]) > eps and len(a) < 64:
        ai = a[-1]
        a.append(0.5 * (ai + b))
        c.append(c[-1] ** 2 / (4.0 * a[-1]))  # = (a_i - b_i) / 2, without cancellation
        b = np.sqrt(ai * b)
    phi = (2.0 ** (len(a) - 1)) * a[-1] * v
    for i in range(len(a) - 1, 0, -1):
        phi = 0.5 * (np.arcsin(c[i] * np.sin(phi) / a[i]) + phi)
    sn = np.sin(phi)
    cn = np.cos(phi)
    dn = np.sqrt(cn * cn + m1 * sn * sn)  # = sqrt(1 - m sn^2) without cancellation
    return sn, cn, dn


def _exact_quadratic(inertia, w, i_ref) -> Fraction:
    """sum_i I_i (I_i - I_ref) w_i^2 = L^2 - 2T I_ref, exactly, from the float data."""
    i_ref = Fraction(float(i_ref))
    total = Fraction(0)
    for i_k, w_k in zip(inertia, w):
        i_k, w_k = Fraction(float(i_k)), Fraction(float(w_k))
        total += i_k * (i_k - i_ref) * w_k * w_k
    return total


def _parity(perm) -> float:
    """+1 for an even (cyclic) permutation of (0, 1, 2), -1 for an odd one."""
    inversions = sum(1 for i in range(3) for j in range(i + 1, 3) if perm[i] > perm[j])
    return -1.0 if inversions % 2 else 1.0


def solve_torque_free(inertia, omega0) -> TorqueFreeSolution:
    """Closed-form solution of torque-free Euler equations for principal inertias in any order.

    inertia: principal moments (I1, I2, I3) in kg m^2, any order, all > 0.
    omega0: body-frame angular velocity at t = 0 in rad/s, any signs.
    Landau & Lifshitz §37 (Jacobi-elliptic solution), relabelled as in the module
    docstring so that the same formulas cover both regimes, the separatrix, axisymmetric
    bodies (m = 0) and equilibria.
    """
    inertia = vector3("inertia", inertia)
    if np.any(inertia <= 0.0):
        raise InputError("inertia", "principal moments of inertia must be > 0")
    w = vector3("omega0", omega0)
    energy = 0.5 * float(np.dot(inertia, w * w))
    momentum = float(np.linalg.norm(inertia * w))
    lo, mid, hi = (int(i) for i in np.argsort(inertia, kind="stable"))
    ia, ib, ic = inertia[lo], inertia[mid], inertia[hi]
    wa, wb, wc = w[lo], w[mid], w[hi]
    common = dict(inertia=tuple(inertia), omega0=tuple(w), energy=energy, momentum=momentum)

    # Equilibrium: every gyroscopic term (I_j - I_k) w_j w_k vanishes exactly.
    gyro = [(ib - ic) * wb * wc, (ic - ia) * wc * wa, (ia - ib) * wa * wb]
    if not any(gyro):
        return TorqueFreeSolution(
            "equilibrium", axes=(lo, mid, hi), amplitudes=(0.0, 0.0, 0.0), sign_c=1.0,
            sense=1.0, m=0.0, m1=1.0, nu=0.0, u0=0.0, period=np.inf, **common)

    # S = L^2 - 2T I_mid is the difference of two non-negative terms; near the separatrix
    # it cancels, so it is formed exactly (rational arithmetic on the float data) and
    # rounded once.  Its relative error is then eps instead of eps / (relative S).
    term_major = ic * (ic - ib) * wc * wc
    term_minor = ia * (ib - ia) * wa * wa
    s_mid = float(_exact_quadratic(inertia, w, ib))
    if abs(s_mid) <= SEPARATRIX_RTOL * (term_major + term_minor):
        return _separatrix(inertia, w, lo, mid, hi, common)
    # c = the axis the polhode encircles; a = the other extreme axis.
    a, b, c = (lo, mid, hi) if s_mid > 0.0 else (hi, mid, lo)
    i_a, i_b, i_c = inertia[a], inertia[b], inertia[c]
    x = abs(float(_exact_quadratic(inertia, w, i_c)))  # |L^2 - 2T I_c|
    y = abs(float(_exact_quadratic(inertia, w, i_a)))  # |L^2 - 2T I_a|
    if x == 0.0:  # underflow of a tiny off-axis component: constant spin to rounding
        return TorqueFreeSolution(
            "equilibrium", axes=(a, b, c), amplitudes=(0.0, 0.0, 0.0), sign_c=1.0,
            sense=1.0, m=0.0, m1=1.0, nu=0.0, u0=0.0, period=np.inf, **common)
    alpha = np.sqrt(x / (i_a * abs(i_c - i_a)))
    beta = np.sqrt(x / (i_b * abs(i_c - i_b)))
    gamma = np.sqrt(y / (i_c * abs(i_c - i_a)))
    nu = np.sqrt(abs(i_c - i_b) * y / (i_a * i_b * i_c))
    # m and 1 - m each from its own cancellation-free formula; keep the small one exact.
    m = abs(i_b - i_a) * x / (abs(i_c - i_b) * y)
    m1 = abs(i_c - i_a) * abs(s_mid) / (abs(i_c - i_b) * y)
    if m1 < 0.5:
        m = 1.0 - m1
    else:
        m1 = 1.0 - m
    sign_c = 1.0 if w[c] > 0.0 else -1.0
    sense = _parity((a, b, c)) * sign_c * np.sign(i_c - i_b)
    kk = float(ellipkm1(m1))
    u0 = _elliptic_phase(w[a] / alpha, w[b] / beta, m1, kk)
    return TorqueFreeSolution(
        "major" if s_mid > 0.0 else "minor", axes=(a, b, c),
        amplitudes=(float(alpha), float(beta), float(gamma)), sign_c=sign_c,
        sense=float(sense), m=float(m), m1=float(m1), nu=float(nu), u0=u0,
        period=4.0 * kk / float(nu), **common)


def _elliptic_phase(cn0: float, sn0: float, m1: float, kk: float) -> float:
    """u0 with cn(u0) = cn0, sn(u0) = sn0, u0 in (-2K, 2K]: the incomplete integral F(phi|m).

    phi = atan2(sn0, cn0) (the amplitude am u0).  For |phi| <= pi/2,
    F = sin(phi) R_F(cos^2 phi, cos^2 phi + m1 sin^2 phi, 1) (DLMF 19.25.5, written with
    m1 so it stays exact near m = 1); for |phi| > pi/2, F(phi) = ±2K - F(±pi - phi).
    """
    r = np.hypot(cn0, sn0)  # = 1 up to rounding; normalise so the branch is exact
    c, s = cn0 / r, sn0 / r
    f = s * float(elliprf(c * c, c * c + m1 * s * s, 1.0))
    if c >= 0.0:
        return float(f)
    return float((2.0 * kk if s >= 0.0 else -2.0 * kk) - f)


def _separatrix(inertia, w, lo, mid, hi, common) -> TorqueFreeSolution:
    """L^2 = 2T I_mid: w_a = ±alpha sech u, w_b = beta tanh u, w_c = ±gamma sech u.

    Landau & Lifshitz §37, problem (the limit m -> 1 of the elliptic solution), with
    a = minor, b = intermediate, c = major axis.  Substituting into Euler's equations in
    the relabelled frame gives the sense s = parity * sign(w_a) * sign(w_c).
    """
    a, b, c = lo, mid, hi
    i_a, i_b, i_c = inertia[a], inertia[b], inertia[c]
    x = abs(float(_exact_quadratic(inertia, w, i_c)))
    y = abs(float(_exact_quadratic(inertia, w, i_a)))
    alpha = np.sqrt(x / (i_a * (i_c - i_a)))
    beta = np.sqrt(x / (i_b * (i_c - i_b)))
    gamma = np.sqrt(y / (i_c * (i_c - i_a)))
    nu = np.sqrt((i_c - i_b) * y / (i_a * i_b * i_c))
    sign_a = 1.0 if w[a] > 0.0 else -1.0
    sign_c = 1.0 if w[c] > 0.0 else -1.0
    sense = _parity((a, b, c)) * sign_a * sign_c
    # sinh u0 = tanh u0 / sech u0; sech u0 is estimated from both extreme components.
    sech0 = 0.5 * (abs(w[a]) / alpha + abs(w[c]) / gamma)
    u0 = float(np.arcsinh((w[b] / beta) / sech0))
    return TorqueFreeSolution(
        "separatrix", axes=(a, b, c), amplitudes=(float(sign_a * alpha), float(beta),
                                                  float(gamma)),
        sign_c=sign_c, sense=float(sense), m=1.0, m1=0.0, nu=float(nu), u0=u0,
        period=np.inf, **common)


def torque_free_omega(inertia, omega0, t) -> np.ndarray:
    """Body-frame angular velocity w(t) (rad/s), shape (len(t), 3), of a torque-free body.

    Closed form (Landau & Lifshitz §37; see ``solve_torque_free``) for principal inertias
    ``inertia`` (kg m^2, any order) and initial body rate ``omega0`` (rad/s).
    """
    return solve_torque_free(inertia, omega0).omega(t)
