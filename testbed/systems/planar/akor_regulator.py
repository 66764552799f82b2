"""Analytic LQR ("AKOR") for planar attitude, with its design formulas (Avdeev & Kaptsova 2016).

Plant (eq. 1-2): x = (angle, rate), x' = a x + b u + c m, a = [[0, 1], [0, 0]],
b = c = (0, 1); u is the actuator angular acceleration, m the disturbance one.
Cost (eq. 3): integral of x' beta x + u k^-1 u, beta = diag(beta11, beta22), so the LQR
weight on u is R = 1/k. Everything here is per unit moment of inertia.

Checked against the original (OCR) by computation:
- eq. 9 (Riccati solution), 11, 12, 13, 15, 17, 18, 19, 20: correct as printed;
- eq. 16: ER0 and ER1[1] are correct; ER1[0] is printed positive, but -(a*)^-2 c gives
  it NEGATIVE: ER1 = (-sqrt(2 sqrt(k b11) + k b22) / (k b11), 1 / sqrt(k b11));
- the imaginary part printed before eq. 20, beta = (2 sqrt(k b11) - b22 k)/2, lacks a
  square root: it is sqrt(2 sqrt(k b11) - b22 k)/2 (only then alpha^2 + beta^2 = k S12,
  which the paper itself uses next);
- eq. 20 is P per unit x10^2 (P scales with the square of the initial offset);
- the Tp = 3/eta "within -35 ... +35 %" claim holds only for part of the complex-root
  range: measured (3/eta - Tp)/Tp runs from +44.8 % (b22 = 0, damping 1/sqrt 2) to
  -36.8 % (double root); see `settling_time_95`.
"""

import numpy as np

from testbed.errors import InputError

A_PLANT = np.array([[0.0, 1.0], [0.0, 0.0]])
B_PLANT = np.array([0.0, 1.0])
C_DIST = np.array([0.0, 1.0])


def check_weights(b11, b22, k):
    """Validate the cost coefficients: beta11 > 0, beta22 >= 0, k > 0 (raise InputError)."""
    if not (np.isfinite(k) and k > 0):
        raise InputError("regulator.k", f"must be > 0, got {k}")
    if not (np.isfinite(b11) and b11 > 0):
        raise InputError("regulator.beta11", f"must be > 0 (angle weight), got {b11}")
    if not (np.isfinite(b22) and b22 >= 0):
        raise InputError("regulator.beta22", f"must be >= 0 (rate weight), got {b22}")


def riccati_closed_form(b11, b22, k):
    """Steady Riccati matrix S (Avdeev & Kaptsova 2016, eq. 9).

    S12 = sqrt(b11/k), S22 = sqrt((2 S12 + b22)/k), S11 = sqrt(b11 (2 S12 + b22)) = k S12 S22,
    the positive root of a'S + S a - S b k b' S + beta = 0 (eq. 8), component by component.
    """
    check_weights(b11, b22, k)
    s12 = np.sqrt(b11 / k)
    s22 = np.sqrt((2.0 * s12 + b22) / k)
    s11 = np.sqrt(b11 * (2.0 * s12 + b22))
    return np.array([[s11, s12], [s12, s22]])


def riccati_scipy(b11, b22, k):
    """The same S from scipy.linalg.solve_continuous_are(a, b, beta, R = 1/k) (eq. 8)."""
    check_weights(b11, b22, k)
    from scipy.linalg import solve_continuous_are  # on use: at the top it would cost every command start-up time
    return solve_continuous_are(A_PLANT, B_PLANT.reshape(2, 1), np.diag([b11, b22]), np.array([[1.0 / k]]))


def lqr_gain(b11, b22, k):
    """Gain g = k (S12, S22) with u = -g . x (eq. 6), S from solve_continuous_are."""
    S = riccati_scipy(b11, b22, k)
    return k * S[1, :]


def control(b11, b22, k, x):
    """Optimal actuator acceleration u = -k (S12 x1 + S22 x2) (eq. 6)."""
    return -float(lqr_gain(b11, b22, k) @ np.asarray(x, dtype=float))


def closed_loop_matrix(b11, b22, k):
    """a* = [[0, 1], [-k S12, -k S22]] (eq. 10); k S12 = sqrt(k b11), k S22 = sqrt(2 sqrt(k b11) + k b22)."""
    S = riccati_closed_form(b11, b22, k)
    return np.array([[0.0, 1.0], [-k * S[0, 1], -k * S[1, 1]]])


def roots_are_real(b11, b22, k):
    """True iff the roots of det(sI - a*) are real: b22 sqrt(k) - 2 sqrt(b11) > 0 (eq. 11).

    (The discriminant of s^2 + k S22 s + k S12 is sqrt(k) (b22 sqrt(k) - 2 sqrt(b11)).)
    The double root (discriminant 0) is counted with the complex case, where eq. 13 holds.
    """
    check_weights(b11, b22, k)
    return b22 * np.sqrt(k) - 2.0 * np.sqrt(b11) > 0


def eta_real(b11, b22, k):
    """Stability margin for real roots, [ (b22 k/2) (1 - sqrt(1 - 4 b11/(b22^2 k))) ]^0.5 (eq. 12)."""
    if not roots_are_real(b11, b22, k):
        raise InputError("regulator.beta22", "eq. 12 needs real roots: b22 sqrt(k) - 2 sqrt(b11) > 0")
    return np.sqrt(0.5 * b22 * k * (1.0 - np.sqrt(1.0 - 4.0 * b11 / (b22**2 * k))))


def eta_complex(b11, b22, k):
    """Stability margin for complex roots, [ sqrt(k) (b22 sqrt(k) + 2 sqrt(b11)) / 4 ]^0.5 (eq. 13).

    This is the real part k S22 / 2 of the root pair.
    """
    check_weights(b11, b22, k)
    return np.sqrt(np.sqrt(k) * (b22 * np.sqrt(k) + 2.0 * np.sqrt(b11)) / 4.0)


def stability_margin(b11, b22, k):
    """eta: distance of the nearest closed-loop root to the imaginary axis (eq. 12 or 13)."""
    return eta_real(b11, b22, k) if roots_are_real(b11, b22, k) else eta_complex(b11, b22, k)


def eta_max(b11, k):
    """Largest margin, reached at the double root: eta_max = (k b11)^(1/4) (eq. 17)."""
    check_weights(b11, 0.0, k)
    return (k * b11) ** 0.25


def beta22_double_root(b11, k):
    """The b22 that puts a* on its double root, b22 = 2 sqrt(b11 / k) (equality in eq. 11)."""
    check_weights(b11, 0.0, k)
    return 2.0 * np.sqrt(b11 / k)


def settling_time_estimate(eta):
    """The paper's rule of thumb Tp ~ 3 / eta (text after eq. 13)."""
    return 3.0 / eta


def error_coefficients(b11, b22, k):
    """ER0 = -(a*)^-1 c, ER1 = -(a*)^-2 c (eq. 15), computed from the matrix a*."""
    ast = closed_loop_matrix(b11, b22, k)
    er0 = -np.linalg.solve(ast, C_DIST)
    er1 = np.linalg.solve(ast, er0)  # -(a*)^-2 c = (a*)^-1 ER0
    return er0, er1


def error_coefficients_closed_form(b11, b22, k):
    """Closed forms of eq. 15 (the correct version of eq. 16).

    ER0 = (1/sqrt(k b11), 0), ER1 = (-sqrt(2 sqrt(k b11) + k b22)/(k b11), 1/sqrt(k b11)).
    From (a*)^-1 = [[-d/w, -1/w], [1, 0]] with w = k S12 = sqrt(k b11), d = k S22.
    """
    check_weights(b11, b22, k)
    w = np.sqrt(k * b11)
    d = np.sqrt(2.0 * w + k * b22)
    return np.array([1.0 / w, 0.0]), np.array([-d / w**2, 1.0 / w])


def error_coefficients_as_printed(b11, b22, k):
    """Eq. 16 as the OCR prints it (fractions rebuilt from the split rows), for comparison.

    ER0 = (1/sqrt(k b11), 0); ER1 = (+(1/b11) sqrt((2 sqrt(b11) + b22 sqrt(k)) / sqrt(k^3)),
    1/sqrt(k b11)). Only the sign of ER1[0] disagrees with eq. 15.
    """
    check_weights(b11, b22, k)
    w = np.sqrt(k * b11)
    er1_0 = np.sqrt((2.0 * np.sqrt(b11) + b22 * np.sqrt(k)) / np.sqrt(k**3)) / b11
    return np.array([1.0 / w, 0.0]), np.array([er1_0, 1.0 / w])


def printed_formula_check(b11, b22, k, rtol=1e-9):
    """Which printed formulas agree with computation at (b11, b22, k): name -> bool.

    Covers eq. 16 component by component (magnitude and sign) and the imaginary part
    printed before eq. 20 (complex roots only).
    """
    er0, er1 = error_coefficients(b11, b22, k)
    p0, p1 = error_coefficients_as_printed(b11, b22, k)
    out = {
        "eq16.ER0": bool(np.allclose(p0, er0, rtol=rtol, atol=0)),
        "eq16.ER1[0].magnitude": bool(np.isclose(abs(p1[0]), abs(er1[0]), rtol=rtol, atol=0)),
        "eq16.ER1[0].sign": bool(np.sign(p1[0]) == np.sign(er1[0])),
        "eq16.ER1[1]": bool(np.isclose(p1[1], er1[1], rtol=rtol, atol=0)),
    }
    if not roots_are_real(b11, b22, k):
        printed_beta = (2.0 * np.sqrt(k * b11) - b22 * k) / 2.0
        out["eq19.beta"] = bool(np.isclose(printed_beta, complex_roots(b11, b22, k)[1], rtol=rtol, atol=0))
    return out


def steady_state(b11, b22, k, m0, m0dot, t):
    """State after the transient under m = m0 + m0' t (eq. 14): m0'(ER0 t + ER1) + ER0 m0."""
    er0, er1 = error_coefficients(b11, b22, k)
    return m0dot * (er0 * t + er1) + er0 * m0


def static_angle_error(b11, k, m0):
    """Static angle error under a constant disturbance m0: m0 / sqrt(k b11) = m0 ER0[0] (eq. 17)."""
    check_weights(b11, 0.0, k)
    return m0 / np.sqrt(k * b11)


def _expm_2x2(M, t):
    """expm(M t) for a real 2x2 M and an array of times t, shape (len(t), 2, 2).

    Cayley-Hamilton: expm(M t) = f0(t) I + f1(t) M with, for eigenvalues
    lam+- = tau/2 +- s (tau = trace, s = sqrt(tau^2/4 - det)),
    f1 = (e^(lam+ t) - e^(lam- t)) / (2 s), f0 = (e^(lam+ t) + e^(lam- t))/2 - (tau/2) f1.
    Written with e^(lam t) (never cosh(s t)) so long horizons do not overflow; a series
    replaces f1 when |s t| is small (double root).
    """
    t = np.asarray(t, dtype=float)
    tau = np.trace(M)
    s = np.sqrt(complex(tau**2 / 4.0 - np.linalg.det(M)))
    ep, em, eh = np.exp((tau / 2 + s) * t), np.exp((tau / 2 - s) * t), np.exp(tau / 2 * t)
    st = s * t
    small = np.abs(st) < 1e-3
    f1 = np.where(small, t * eh * (1 + st**2 / 6), (ep - em) / (2 * np.where(small, 1.0, s)))
    f0 = (ep + em) / 2 - tau / 2 * f1
    out = f0.real[:, None, None] * np.eye(2) + f1.real[:, None, None] * M
    return out


def response(b11, b22, k, x0, t, m0=0.0, m0dot=0.0):
    """Exact closed-loop state x(t) from x(0) = x0 under m = m0 + m0' t (eq. 10, 14).

    x(t) = x_ss(t) + expm(a* t) (x0 - x_ss(0)), x_ss from `steady_state`.
    Accepts scalar t or an array of times; returns shape (2,) or (len(t), 2).
    """
    ast = closed_loop_matrix(b11, b22, k)
    er0, er1 = error_coefficients(b11, b22, k)
    x0 = np.asarray(x0, dtype=float)
    e0 = x0 - (m0dot * er1 + er0 * m0)
    ts = np.atleast_1d(np.asarray(t, dtype=float))
    xs = m0dot * (er0 * ts[:, None] + er1) + er0 * m0 + _expm_2x2(ast, ts) @ e0
    return xs[0] if np.ndim(t) == 0 else xs


def settling_time_95(b11, b22, k):
    """Exact Tp: last time the angle is outside 5 % of its final value after a step m0.

    (Avdeev & Kaptsova 2016, definition before Fig. 2.) The step response of the angle is
    ER0[0] m0 (1 - phi11(t)), phi = expm(a* t), the same curve as the free decay from an
    initial offset, so Tp is the last t with |phi11(t)| > 0.05.
    """
    ast = closed_loop_matrix(b11, b22, k)
    eta = stability_margin(b11, b22, k)
    # Sample up to 25 / eta (a double root's (1 + eta t) e^(-eta t) is 5e-10 there), then refine.
    T = np.linspace(0.0, 25.0 / eta, 5001)
    phi = _expm_2x2(ast, T)[:, 0, 0]
    i = np.nonzero(np.abs(phi) > 0.05)[0].max()

    def g(t):
        return abs(_expm_2x2(ast, [t])[0, 0, 0]) - 0.05

    from scipy.optimize import brentq, minimize_scalar  # on use: at the top it would cost every command start-up time
    return brentq(g, T[i], T[i + 1], xtol=1e-12 / eta)


def power(b11, b22, k, x):
    """Actuator power per unit inertia P = -k (S12 x1 + S22 x2) x2 (eq. 18); x may be (..., 2)."""
    x = np.asarray(x, dtype=float)
    S = riccati_closed_form(b11, b22, k)
    return -k * (S[0, 1] * x[..., 0] + S[1, 1] * x[..., 1]) * x[..., 1]


def complex_roots(b11, b22, k):
    """(alpha, beta) of the root pair -alpha +- j beta: alpha = k S22/2, alpha^2 + beta^2 = k S12.

    beta = sqrt(2 sqrt(k b11) - k b22) / 2 (the printed text before eq. 20 drops the root).
    """
    if roots_are_real(b11, b22, k):
        raise InputError("regulator.beta22", "roots are real (eq. 11 holds): no complex pair")
    w = np.sqrt(k * b11)
    return np.sqrt(2.0 * w + k * b22) / 2.0, np.sqrt(max(2.0 * w - k * b22, 0.0)) / 2.0


def power_closed_form(b11, b22, k, x10, t):
    """P(t) after an initial offset x(0) = (x10, 0), complex roots (eq. 19-20).

    P = x10^2 (alpha^2 + beta^2)^2 / beta e^(-2 alpha t) (cos beta t - (alpha/beta) sin beta t) sin beta t.
    """
    al, be = complex_roots(b11, b22, k)
    if be == 0.0:
        raise InputError("regulator.beta22", "double root: eq. 20 divides by beta = 0")
    t = np.asarray(t, dtype=float)
    r = al**2 + be**2
    return x10**2 * r**2 / be * np.exp(-2 * al * t) * (np.cos(be * t) - al / be * np.sin(be * t)) * np.sin(be * t)


def peak_power(b11, b22, k, x10):
    """(t_peak, P_peak): the largest power demand after an offset x(0) = (x10, 0) (eq. 18-20).

    Complex roots: dP/dt = 0 at 2 beta t = arccos(-alpha^2 / r) - 2 atan2(alpha, beta),
    r = alpha^2 + beta^2 (derived from eq. 20; the first stationary point is the maximum).
    Real or double roots: maximise eq. 18 numerically on the exact response (`response`).
    """
    if not roots_are_real(b11, b22, k):
        al, be = complex_roots(b11, b22, k)
        if be > 0:
            r = al**2 + be**2
            tp = (np.arccos(-(al**2) / r) - 2.0 * np.arctan2(al, be)) / (2.0 * be)
            return float(tp), float(power_closed_form(b11, b22, k, x10, tp))
    eta = stability_margin(b11, b22, k)
    fast = np.max(np.abs(np.linalg.eigvals(closed_loop_matrix(b11, b22, k))))
    # Two grids: the hump sits on the fast root's time scale, the tail on the slow one's.
    T = np.unique(np.concatenate([np.linspace(0.0, 10.0 / fast, 2001), np.linspace(0.0, 10.0 / eta, 2001)]))
    P = power(b11, b22, k, response(b11, b22, k, [x10, 0.0], T))
    i = int(np.argmax(P))
    lo, hi = T[max(i - 1, 0)], T[min(i + 1, T.size - 1)]
    from scipy.optimize import brentq, minimize_scalar
    res = minimize_scalar(lambda t: -power(b11, b22, k, response(b11, b22, k, [x10, 0.0], t)),
                          bounds=(lo, hi), method="bounded", options={"xatol": 1e-10 / eta})
    return float(res.x), float(-res.fun)
