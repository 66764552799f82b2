"""The Euler angles of Bezglasny & Khudyakova (seed 002): q = (phi, psi, theta).

Classical z-x-z sequence (the paper cites Markeev's textbook): precession psi about the
fixed Z axis, nutation theta about the line of nodes, proper rotation phi about the body z
axis, so the body-to-world rotation is R = Rz(psi) Rx(theta) Rz(phi) and the quaternion
(w, x, y, z) is qz(psi) o qx(theta) o qz(phi):

    w = cos(theta/2) cos((psi + phi)/2),   x = sin(theta/2) cos((psi - phi)/2),
    y = sin(theta/2) sin((psi - phi)/2),   z = cos(theta/2) sin((psi + phi)/2).

Body rates (Bezglasny & Khudyakova, the kinematic equations before (2.2)):

    p = theta' cos phi + psi' sin phi sin theta
    q = -theta' sin phi + psi' cos phi sin theta
    r = phi' + psi' cos theta

The sequence is singular at theta = 0 and pi (psi and phi turn about the same axis).
"""

from __future__ import annotations

import numpy as np



def quat_from_euler(angles) -> np.ndarray:
    """Unit quaternion (w, x, y, z), body to world, of (phi, psi, theta): qz(psi) o qx(theta) o qz(phi),
    by the closed form of the module docstring."""
    phi, psi, theta = angles
    ct, st = np.cos(theta / 2), np.sin(theta / 2)
    s, d = (psi + phi) / 2, (psi - phi) / 2
    return np.array([ct * np.cos(s), st * np.cos(d), st * np.sin(d), ct * np.sin(s)])


def euler_from_quat(quat) -> np.ndarray:
    """(phi, psi, theta) of a unit quaternion: phi, psi in (-pi, pi], theta in [0, pi].

    From the closed form in the module docstring: (psi + phi)/2 = atan2(z, w),
    (psi - phi)/2 = atan2(y, x), theta/2 = atan2(|(x, y)|, |(w, z)|); atan2 keeps full
    precision near every angle. The sign of q only shifts psi by 2 pi. At theta = 0 psi is
    set to 0, at theta = pi phi is set to 0 (the gimbal-lock convention).
    """
    w, x, y, z = np.asarray(quat, float) / np.linalg.norm(quat)
    theta = 2.0 * np.arctan2(np.hypot(x, y), np.hypot(w, z))
    s = np.arctan2(z, w) if np.hypot(w, z) > 0 else None  # (psi + phi) / 2
    d = np.arctan2(y, x) if np.hypot(x, y) > 0 else None  # (psi - phi) / 2
    if d is None:
        d = -s  # theta = 0: psi = s + d = 0
    if s is None:
        s = d   # theta = pi: phi = s - d = 0
    return np.array([_wrap(s - d), _wrap(s + d), theta])


def body_rates(angles, angle_rates) -> np.ndarray:
    """Body-frame angular velocity (p, q, r) from (phi, psi, theta) and their rates.

    Bezglasny & Khudyakova: p = theta' cos phi + psi' sin phi sin theta,
    q = -theta' sin phi + psi' cos phi sin theta, r = phi' + psi' cos theta.
    """
    phi, _, theta = angles
    dphi, dpsi, dtheta = angle_rates
    return np.array([dtheta * np.cos(phi) + dpsi * np.sin(phi) * np.sin(theta),
                     -dtheta * np.sin(phi) + dpsi * np.cos(phi) * np.sin(theta),
                     dphi + dpsi * np.cos(theta)])


def rate_matrix(q) -> np.ndarray:
    """E(q) with w = E q' (the rates of `body_rates` as a matrix)."""
    phi, _, theta = q
    sf, cf, st, ct = np.sin(phi), np.cos(phi), np.sin(theta), np.cos(theta)
    return np.array([[0.0, sf * st, cf], [0.0, cf * st, -sf], [1.0, ct, 0.0]])


def rate_matrix_dot_times(q, qd) -> np.ndarray:
    """E'(q, q') q': the part of w' = E q'' + E' q' that does not hold q''."""
    phi, _, theta = q
    dphi, dpsi, dtheta = qd
    sf, cf, st, ct = np.sin(phi), np.cos(phi), np.sin(theta), np.cos(theta)
    return np.array([-dtheta * sf * dphi + dpsi * (cf * st * dphi + sf * ct * dtheta),
                     -dtheta * cf * dphi + dpsi * (-sf * st * dphi + cf * ct * dtheta),
                     -dpsi * st * dtheta])


def angle_rates(angles, omega_body) -> np.ndarray:
    """(phi', psi', theta') from (phi, psi, theta) and body rates (p, q, r): the inverse of
    `body_rates`,

        psi' = (p sin phi + q cos phi) / sin theta,   theta' = p cos phi - q sin phi,
        phi' = r - psi' cos theta.

    Works on one state (3,) or on histories (..., 3). For one state it raises ValueError at
    the gimbal lock sin theta = 0, where psi' and phi' are undefined (histories get inf there).
    """
    angles, omega_body = np.asarray(angles, float), np.asarray(omega_body, float)
    phi, theta = angles[..., 0], angles[..., 2]
    p, q, r = omega_body[..., 0], omega_body[..., 1], omega_body[..., 2]
    st = np.sin(theta)
    if st.ndim == 0 and abs(st) < 1e-12:
        raise ValueError(f"Euler angles (z-x-z) are singular at theta = {theta:g}: sin(theta) = 0")
    dpsi = (p * np.sin(phi) + q * np.cos(phi)) / st
    return np.stack([r - dpsi * np.cos(theta), dpsi, p * np.cos(phi) - q * np.sin(phi)], axis=-1)


def wrap_angle(angle):
    """Angles wrapped to [-pi, pi] (atan2 of sin and cos; arrays elementwise)."""
    return np.arctan2(np.sin(angle), np.cos(angle))


def _wrap(angle: float) -> float:
    """Angle wrapped to (-pi, pi]."""
    wrapped = wrap_angle(angle)
    return float(np.pi if wrapped == -np.pi else wrapped)
