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

from testbed.math.quaternion import length, quat_conj, quat_from_rotation_vector, quat_mul, rotation_vector

I3 = np.eye(3)
H = np.hstack([I3, np.zeros((3, 3))])
# w Δt below this: Φ by its series to second order (the closed form loses digits there)
SERIES_BELOW = 1e-6


# [v×] = v @ _SKEW_BASIS (rows v_x, v_y, v_z of the flattened 3 x 3): products by 0 and ±1, exact
_SKEW_BASIS = np.array([[0, 0, 0, 0, 0, -1, 0, 1, 0], [0, 0, 1, 0, 0, 0, -1, 0, 0], [0, -1, 0, 1, 0, 0, 0, 0, 0]], float)
# Q = a _ANGLE + c _CROSS + r _RATE: the 3 x 3 blocks of the process noise (module doc)
_ANGLE, _CROSS, _RATE = (np.kron(block, I3) for block in ([[1.0, 0.0], [0.0, 0.0]], [[0.0, 1.0], [1.0, 0.0]],
                                                           [[0.0, 0.0], [0.0, 1.0]]))


def skew(v) -> np.ndarray:
    """[v×] (..., 3, 3) of v (..., 3): skew(v) @ u = v × u."""
    v = np.asarray(v, float)
    return (v @ _SKEW_BASIS).reshape(v.shape[:-1] + (3, 3))


def transposed(m) -> np.ndarray:
    """The transposes of (..., r, c) matrices."""
    return np.swapaxes(m, -1, -2)


def _rows(x):
    """A number as it is; an array of one per filter as (..., 1, 1), to scale their matrices."""
    return np.asarray(x, float)[..., None, None] if np.ndim(x) else x


def transition(omega, dt) -> np.ndarray:
    """Φ (..., 6, 6) of the error state over dt [s] (a number or (...,)) at the held rate omega
    (..., 3) [rad/s] (module doc), as Φ₁₁ = I + a [ω̂×] + b [ω̂×]², Φ₁₂ = b [ω̂×] - I Δt + e [ω̂×]²;
    below w Δt = SERIES_BELOW the coefficients' series to second order (a = -Δt, b = Δt²/2,
    e = -Δt³/6), where the closed form loses digits."""
    dt, w = _rows(dt), length(omega)
    w = w[..., None] if np.ndim(w) else w  # (..., 1, 1) rows, or one number
    cross = skew(omega)
    square = cross @ cross
    series = w * dt < SERIES_BELOW
    w = np.where(series, 1.0, w)  # (rows the series serves: no division by 0)
    s, c = np.sin(w * dt), np.cos(w * dt)
    a = np.where(series, -dt, -s / w)
    b = np.where(series, dt**2 / 2, (1 - c) / w**2)
    e = np.where(series, -dt**3 / 6, -(w * dt - s) / w**3)
    phi = np.zeros(cross.shape[:-2] + (6, 6))
    phi[..., 3:, 3:] = I3
    phi[..., :3, :3] = I3 + a * cross + b * square
    phi[..., :3, 3:] = b * cross - dt * I3 + e * square
    return phi


def process_noise(arw, rrw, dt) -> np.ndarray:
    """Q (..., 6, 6) over dt [s] for angle random walk σ_v and rate random walk σ_u (numbers or
    (...,) arrays) (module doc)."""
    arw, rrw, dt = _rows(arw), _rows(rrw), _rows(dt)
    return ((arw**2 * dt + rrw**2 * dt**3 / 3) * _ANGLE + (-rrw**2 * dt**2 / 2) * _CROSS
            + (rrw**2 * dt) * _RATE)


class Mekf:
    """The filter of the module doc; `arw`, `rrw` the gyro model it is tuned to. Its arithmetic
    broadcasts over a leading axis of filters (quat (N, 4), bias (N, 3), covariance (N, 6, 6),
    arw and rrw (N,)): the filters of a batch's worlds (testbed.mekf.worlds)."""

    def __init__(self, quat, bias, covariance, arw, rrw):
        quat = np.asarray(quat, float)
        self.quat = quat / length(quat)
        self.bias = np.array(bias, float)
        self.covariance = np.array(covariance, float)
        self.arw, self.rrw = arw, rrw

    def propagate(self, rate: np.ndarray, dt) -> None:
        """Advance over dt [s] (a number or (N,)) with the gyro's mean rate `rate` [rad/s] over that interval."""
        omega = rate - self.bias
        self.quat = quat_mul(self.quat, quat_from_rotation_vector(omega * (np.asarray(dt)[..., None] if np.ndim(dt) else dt)))
        phi = transition(omega, dt)
        self.covariance = phi @ self.covariance @ transposed(phi) + process_noise(self.arw, self.rrw, dt)

    def innovation(self, measured) -> np.ndarray:
        """z = rotvec(q̂~ ∘ q̃) [rad, body axes] of a measured attitude q̃."""
        return rotation_vector(quat_mul(quat_conj(self.quat), measured))

    def update(self, z: np.ndarray, noise: np.ndarray):
        """The attitude update with innovation z and measurement covariance `noise` (module doc);
        returns the normalised innovation squared zᵀ S⁻¹ z (a number, or (N,))."""
        p = self.covariance
        s = p[..., :3, :3] + noise
        gain = transposed(np.linalg.solve(s, p[..., :3, :]))  # P Hᵀ S⁻¹ (S, P symmetric)
        dx = np.matvec(gain, z)
        quat = quat_mul(self.quat, quat_from_rotation_vector(dx[..., :3]))
        self.quat = quat / length(quat)
        self.bias = self.bias + dx[..., 3:]
        joseph = np.eye(6) - gain @ H
        self.covariance = joseph @ p @ transposed(joseph) + gain @ noise @ transposed(gain)
        return np.vecdot(z, np.linalg.solve(s, z[..., None])[..., 0])
