"""MEKF (Lefferts, Markley & Shuster 1982, "Kalman filtering for spacecraft attitude
estimation", JGCD 5(5)), in the body-frame error convention q = q̂ ∘ exp(δθ / 2).

State q̂ (w, x, y, z, body to world) and gyro bias β̂; error state x = (δθ, δβ), covariance P.

Propagation over Δt with ω̂ = ω̃ - β̂ held (Crassidis & Junkins, "Optimal Estimation of
Dynamic Systems", 2nd ed., ch. 7, the discrete MEKF):
    q̂⁺ = q̂ ∘ exp(ω̂ Δt / 2),   P⁺ = Φ P Φᵀ + Q
    Φ₁₁ = I - [ω̂×] s/w + [ω̂×]² (1 - c)/w²,   Φ₁₂ = [ω̂×] (1 - c)/w² - I Δt - [ω̂×]² (wΔt - s)/w³
    (w = |ω̂|, s = sin wΔt, c = cos wΔt), Φ₂₁ = 0, Φ₂₂ = I,
    Q = [[(σ_v² Δt + σ_u² Δt³/3) I, -σ_u² Δt²/2 I], [-σ_u² Δt²/2 I, σ_u² Δt I]].
Attitude update with a measured q̃ of covariance R (body axes):
    z = rotvec(q̂~ ∘ q̃),  H = [I 0],  S = H P Hᵀ + R,  K = P Hᵀ S⁻¹,  δx = K z,
    q̂ ← q̂ ∘ exp(δθ / 2),  β̂ ← β̂ + δβ,  P ← (I - KH) P (I - KH)ᵀ + K R Kᵀ (Joseph form).
"""

from __future__ import annotations

import numpy as np

from testbed.math.quaternion import quat_conj, quat_from_rotation_vector, quat_mul, rotation_vector

I3 = np.eye(3)
H = np.hstack([I3, np.zeros((3, 3))])


def skew(v) -> np.ndarray:
    """[v×]: skew(v) @ u = v × u."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def transition(omega: np.ndarray, dt: float) -> np.ndarray:
    """Φ of the error state over dt at the held rate omega (module doc)."""
    w = float(np.linalg.norm(omega))
    cross = skew(omega)
    phi = np.eye(6)
    if w * dt < 1e-6:  # the series to second order: the closed form loses digits here
        phi[:3, :3] = I3 - cross * dt + cross @ cross * dt**2 / 2
        phi[:3, 3:] = -I3 * dt + cross * dt**2 / 2 - cross @ cross * dt**3 / 6
        return phi
    s, c = np.sin(w * dt), np.cos(w * dt)
    phi[:3, :3] = I3 - cross * s / w + cross @ cross * (1 - c) / w**2
    phi[:3, 3:] = cross * (1 - c) / w**2 - I3 * dt - cross @ cross * (w * dt - s) / w**3
    return phi


def process_noise(arw: float, rrw: float, dt: float) -> np.ndarray:
    """Q over dt for angle random walk σ_v and rate random walk σ_u (module doc)."""
    q = np.zeros((6, 6))
    q[:3, :3] = (arw**2 * dt + rrw**2 * dt**3 / 3) * I3
    q[:3, 3:] = q[3:, :3] = -rrw**2 * dt**2 / 2 * I3
    q[3:, 3:] = rrw**2 * dt * I3
    return q


class Mekf:
    """The filter of the module doc; `arw`, `rrw` the gyro model it is tuned to."""

    def __init__(self, quat, bias, covariance, arw: float, rrw: float):
        self.quat = np.asarray(quat, float) / np.linalg.norm(quat)
        self.bias = np.array(bias, float)
        self.covariance = np.array(covariance, float)
        self.arw, self.rrw = arw, rrw

    def propagate(self, rate: np.ndarray, dt: float) -> None:
        """Advance over dt with the gyro's mean rate `rate` [rad/s] over that interval."""
        omega = rate - self.bias
        self.quat = quat_mul(self.quat, quat_from_rotation_vector(omega * dt))
        phi = transition(omega, dt)
        self.covariance = phi @ self.covariance @ phi.T + process_noise(self.arw, self.rrw, dt)

    def innovation(self, measured) -> np.ndarray:
        """z = rotvec(q̂~ ∘ q̃) [rad, body axes] of a measured attitude q̃."""
        return rotation_vector(quat_mul(quat_conj(self.quat), measured))

    def update(self, z: np.ndarray, noise: np.ndarray) -> float:
        """The attitude update with innovation z and measurement covariance `noise` (module doc);
        returns the normalised innovation squared zᵀ S⁻¹ z."""
        p = self.covariance
        s = p[:3, :3] + noise
        gain = np.linalg.solve(s, p[:3, :]).T  # P Hᵀ S⁻¹ (S, P symmetric)
        dx = gain @ z
        self.quat = quat_mul(self.quat, quat_from_rotation_vector(dx[:3]))
        self.quat /= np.linalg.norm(self.quat)
        self.bias = self.bias + dx[3:]
        joseph = np.eye(6) - gain @ H
        self.covariance = joseph @ p @ joseph.T + gain @ noise @ gain.T
        return float(z @ np.linalg.solve(s, z))
