"""Invariant-manifold observer and synchronisation law for two gyrostats (seed 003, eqs. 1-15).

Gyrostat with three rotors (eq. 1), inertias A_i including the rotors, gyrostatic moment
lambda (rotor momentum relative to the body):

    A1 w1' = (A2 - A3) w2 w3 + l2 w3 - l3 w2 - l1'      (cyclic), i.e.
    A w' = -w x (A w + lambda) - lambda'.

Leader: lambda constant; w1, w2 and lambda are measured, w3 is not. With
a1 = (A2 - A3)/A1, a2 = (A3 - A1)/A2, a3 = (A1 - A2)/A3 and a_ij = l_i / A_j, the leader is

    w1' = b1 w3 - a31 w2,   w2' = b2 w3 + a32 w1,   w3' = a3 w1 w2 + a13 w2 - a23 w1,
    b1 = a1 w2 + a21,       b2 = a2 w1 - a12.

(lambda_2 multiplies w3 in A1 w1', so its coefficient is l2/A1 = a21; -l1 w3 in A2 w2'
gives -a12. This fixes the index pairs the OCR swaps.)

Observer (3), v_i = u_i / A_i, state p:

    p1' = b1 p3 - a31 w2 - v1,  p2' = b2 p3 + a32 w1 - v2,  p3' = a3 w1 w2 + a13 w2 - a23 w1 - v3.

Errors e = w - p (4): e1' = b1 e3 + v1, e2' = b2 e3 + v2, e3' = v3. Writing e3 = Phi + eta
(7) and differentiating Phi(e1, e2, w1, w2) along (1), (4) gives

    eta' = v3 - Phi_e1 (b1 Phi + v1) - Phi_e2 (b2 Phi + v2)
               - Phi_w1 (b1 (p3 + Phi) - a31 w2) - Phi_w2 (b2 (p3 + Phi) + a32 w1)
               - [(Phi_e1 + Phi_w1) b1 + (Phi_e2 + Phi_w2) b2] eta.

Index-consistent (8):  v3 = gamma Phi + Phi_e1 v1 + Phi_e2 v2
                            + Phi_w1 (b1 p3 - a31 w2) + Phi_w2 (b2 p3 + a32 w1)
(the OCR's "Phi_w1 (p3 - a13 w2) + Phi_w2 (p3 + a23 w1)" drops b1, b2 and swaps indices),
with Phi solving the PDE (10), index-consistent:

    (Phi_e1 + Phi_w1) b1 + (Phi_e2 + Phi_w2) b2 = gamma,

so that eta' = -gamma eta (9). (13): v1 = -gamma e1 - b1 Phi, v2 = -gamma e2 - b2 Phi give
(14): e1' = b1 eta - gamma e1, e2' = b2 eta - gamma e2, eta' = -gamma eta.

Solution of (10) with Phi(0, 0, w1, w2) = 0 (section 3): Phi = G(w1, w2) - G(p1, p2) where G
solves G_w1 b1 + G_w2 b2 = gamma. With x = a2 w1 - a12 (= b2), y = a1 w2 + a21 (= b1):

- a1 a2 < 0 (A3 largest or smallest), k = sqrt(-a1 a2): the "arctan" form (11)
      G = (gamma / k) arctan(k x / (a2 y)),
  evaluated as the continuous angle atan2(k x, a2 y) and differenced (wrapped to (-pi, pi])
  between w and p, so the observer never sees the arctan's branch jumps;
- a1 a2 > 0 (A3 intermediate), k = sqrt(a1 a2): the "log" form (12)
      G = (gamma / k) ln|a1 x + k y|.
  (The OCR's (11) carries a minus sign and sqrt(a1 a2) of a negative number, and (12) lacks
  the 1/k factor; both versions here satisfy (10) exactly, see the tests.)
Singular sets: x = y = 0 (b1 = b2 = 0: w3 is unobservable there) for the arctan form, the
line a1 x + k y = 0 for the log form; trajectories of w and p must stay clear of them.

Synchronisation (15): follower (2), A p' = -p x (A p + q) - q', with
q' = Q = [-p x (A p + q)] - A (observer right-hand side of (3)), which turns (2) into (3), so
p -> w at the observer's rate.
"""

from __future__ import annotations

import numpy as np

from testbed.errors import InputError


class InvariantManifoldObserver:
    """Observer (3), (8), (13) for a leader gyrostat with inertias A, constant moment lambda."""

    def __init__(self, inertia, gyrostatic_moment, gamma: float, path: str = "observer"):
        A = np.asarray(inertia, float)
        lam = np.asarray(gyrostatic_moment, float)
        if A.shape != (3,) or not np.all(np.isfinite(A)) or np.any(A <= 0):
            raise InputError(f"{path}.inertia", f"must be three positive moments of inertia, got {list(A)}")
        if lam.shape != (3,) or not np.all(np.isfinite(lam)):
            raise InputError(f"{path}.gyrostatic_moment", f"must be three finite numbers, got {list(lam)}")
        if not np.isfinite(gamma) or gamma <= 0:
            raise InputError(f"{path}.gamma", "must be > 0")
        scale = A.max()
        if abs(A[2] - A[1]) <= 1e-12 * scale:
            raise InputError(f"{path}.inertia", "A3 = A2 makes a1 = (A2 - A3)/A1 vanish: w3 cannot be observed")
        if abs(A[2] - A[0]) <= 1e-12 * scale:
            raise InputError(f"{path}.inertia", "A3 = A1 makes a2 = (A3 - A1)/A2 vanish: w3 cannot be observed")
        self.A, self.lam, self.gamma = A, lam, float(gamma)
        self.a1 = (A[1] - A[2]) / A[0]
        self.a2 = (A[2] - A[0]) / A[1]
        self.a3 = (A[0] - A[1]) / A[2]
        self.a = np.outer(lam, 1.0 / A)  # a[i, j] = lambda_i / A_j (0-based indices)
        self.form = "arctan" if self.a1 * self.a2 < 0 else "log"
        self.k = float(np.sqrt(abs(self.a1 * self.a2)))

    # --- the manifold function Phi and its gradient ---------------------------------------
    def _xy(self, w1, w2):
        """x = a2 w1 - a12 (= b2) and y = a1 w2 + a21 (= b1)."""
        return self.a2 * w1 - self.a[0, 1], self.a1 * w2 + self.a[1, 0]

    def _grad_g(self, w1, w2) -> np.ndarray:
        """(G_w1, G_w2) of the particular solution G of (10) (see module docstring)."""
        x, y = self._xy(w1, w2)
        g = self.gamma
        if self.form == "arctan":
            den = (self.k * x) ** 2 + (self.a2 * y) ** 2
            return np.array([g * self.a2**2 * y / den, -g * self.a1 * self.a2 * x / den])
        lin = self.a1 * x + self.k * y
        return np.array([g * self.k / lin, g * self.a1 / lin])

    def manifold(self, e1, e2, w1, w2) -> float:
        """Phi(e1, e2, w1, w2) = G(w1, w2) - G(w1 - e1, w2 - e2): solves (10), Phi(0, 0, .) = 0."""
        xw, yw = self._xy(w1, w2)
        xp, yp = self._xy(w1 - e1, w2 - e2)
        if self.form == "arctan":
            # Difference of the angles atan2(k x, a2 y) at w and at p, wrapped: eq. (11).
            u_w, u_p = np.array([self.a2 * yw, self.k * xw]), np.array([self.a2 * yp, self.k * xp])
            delta = np.arctan2(u_p[0] * u_w[1] - u_p[1] * u_w[0], u_p @ u_w)
            return self.gamma / self.k * float(delta)
        ratio = (self.a1 * xw + self.k * yw) / (self.a1 * xp + self.k * yp)
        if ratio <= 0:
            raise ValueError("log-form manifold: w and p lie on opposite sides of a1 x + k y = 0")
        return self.gamma / self.k * float(np.log(ratio))  # eq. (12)

    def manifold_gradient(self, e1, e2, w1, w2) -> np.ndarray:
        """(Phi_e1, Phi_e2, Phi_w1, Phi_w2): Phi_e = grad G(p), Phi_w = grad G(w) - grad G(p)."""
        gw = self._grad_g(w1, w2)
        gp = self._grad_g(w1 - e1, w2 - e2)
        return np.array([gp[0], gp[1], gw[0] - gp[0], gw[1] - gp[1]])

    # --- observer ---------------------------------------------------------------------------
    def controls(self, w1, w2, p) -> np.ndarray:
        """v = (v1, v2, v3) of (13) and the index-consistent (8), at measurement w1, w2, state p."""
        p1, p2, p3 = p
        e1, e2 = w1 - p1, w2 - p2
        a, g = self.a, self.gamma
        b1, b2 = self.a1 * w2 + a[1, 0], self.a2 * w1 - a[0, 1]
        phi = self.manifold(e1, e2, w1, w2)
        phi_e1, phi_e2, phi_w1, phi_w2 = self.manifold_gradient(e1, e2, w1, w2)
        v1 = -g * e1 - b1 * phi
        v2 = -g * e2 - b2 * phi
        v3 = (g * phi + phi_e1 * v1 + phi_e2 * v2
              + phi_w1 * (b1 * p3 - a[2, 0] * w2) + phi_w2 * (b2 * p3 + a[2, 1] * w1))
        return np.array([v1, v2, v3])

    def rate(self, w1, w2, p) -> np.ndarray:
        """p' of the observer system (3) divided by A_i, with v from `controls`."""
        v = self.controls(w1, w2, p)
        a = self.a
        b1, b2 = self.a1 * w2 + a[1, 0], self.a2 * w1 - a[0, 1]
        return np.array([b1 * p[2] - a[2, 0] * w2 - v[0],
                         b2 * p[2] + a[2, 1] * w1 - v[1],
                         self.a3 * w1 * w2 + a[0, 2] * w2 - a[1, 2] * w1 - v[2]])

    def estimate(self, w1, w2, p) -> np.ndarray:
        """Estimate of the leader's w: (p1, p2, p3 + Phi(e1, e2, w1, w2)) (eq. 6)."""
        return np.array([p[0], p[1], p[2] + self.manifold(w1 - p[0], w2 - p[1], w1, w2)])

    def manifold_error(self, w, p) -> float:
        """eta = e3 - Phi (eq. 7): the distance from the invariant manifold, given the true w."""
        return float(w[2] - p[2] - self.manifold(w[0] - p[0], w[1] - p[1], w[0], w[1]))

    # --- synchronisation --------------------------------------------------------------------
    def synchronisation_law(self, w1, w2, p, q) -> np.ndarray:
        """Follower rotor-momentum rate q' = Q(w1, w2, p, q) of (15).

        Q = -p x (A p + q) - A * (observer rate (3) at state p): substituted into the
        follower's (2), A p' = -p x (A p + q) - q', it leaves A p' = A * (observer rate).
        """
        p = np.asarray(p, float)
        q = np.asarray(q, float)
        return -np.cross(p, self.A * p + q) - self.A * self.rate(w1, w2, p)
