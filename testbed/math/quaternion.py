"""Quaternion algebra in MuJoCo's convention: q = (w, x, y, z), Hamilton product.

`q` maps body-frame vectors to the world frame: v_world = q ∘ v_body ∘ q~.
"""

import mujoco
import numpy as np

from testbed.math.cross import cross3


def quat_mul(p, q):
    """Hamilton product p ∘ q (works on (4,) or broadcast (..., 4) arrays)."""
    p = np.asarray(p, dtype=float)
    q = np.asarray(q, dtype=float)
    pw, pv = p[..., :1], p[..., 1:]
    qw, qv = q[..., :1], q[..., 1:]
    w = pw * qw - np.sum(pv * qv, axis=-1, keepdims=True)
    v = pw * qv + qw * pv + cross3(pv, qv)
    return np.concatenate([w, v], axis=-1)


def quat_conj(q):
    """Conjugate q~ (the inverse of a unit quaternion)."""
    q = np.asarray(q, dtype=float)
    return np.concatenate([q[..., :1], -q[..., 1:]], axis=-1)


def quat_from_axis_angle(axis, angle):
    """Unit quaternion cos(angle/2) + axis sin(angle/2); `axis` must be a unit vector."""
    axis = np.asarray(axis, dtype=float)
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])


def quat_rotate(q, v):
    """Rotate vector v by unit quaternion q: the vector part of q ∘ v ∘ q~."""
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float)
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * cross3(u, v)
    return v + w * t + cross3(u, t)


def quat_angle(q):
    """Rotation angle in [0, pi] of unit quaternion q (sign-invariant)."""
    q = np.asarray(q, dtype=float)
    vn = np.linalg.norm(q[..., 1:], axis=-1)
    return 2.0 * np.arctan2(vn, np.abs(q[..., 0]))


def quat_to_matrix(q):
    """Rotation matrix of unit quaternion q (MuJoCo's mju_quat2Mat), (3, 3)."""
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, np.asarray(q, dtype=float))
    return mat.reshape(3, 3)


def quat_from_rotation_vector(theta):
    """Unit quaternion exp(theta/2) = (cos |theta|/2, sin(|theta|/2) theta/|theta|) of a rotation vector [rad]."""
    theta = np.asarray(theta, dtype=float)
    angle = float(np.linalg.norm(theta))
    if angle == 0.0:
        return np.array([1.0, 0.0, 0.0, 0.0])
    return quat_from_axis_angle(theta / angle, angle)


def rotation_vector(q):
    """theta = angle * axis of unit quaternion q, the short way (angle in [0, pi]) [rad]."""
    q = np.asarray(q, dtype=float)
    q = q if q[0] >= 0 else -q
    s = float(np.linalg.norm(q[1:]))
    if s == 0.0:
        return np.zeros(3)
    return 2.0 * np.arctan2(s, q[0]) * q[1:] / s


def rotation_vectors(q):
    """theta (..., 3) of unit quaternions q (..., 4), row by row as `rotation_vector` (the norms
    summed along the last axis, so that a row's value does not depend on the rows beside it) [rad]."""
    q = np.asarray(q, dtype=float)
    q = np.where(q[..., :1] >= 0, q, -q)
    s = np.sqrt(np.sum(q[..., 1:] * q[..., 1:], axis=-1, keepdims=True))
    with np.errstate(invalid="ignore", divide="ignore"):  # s = 0 (no rotation) is taken apart below
        theta = 2.0 * np.arctan2(s, q[..., :1]) * q[..., 1:] / s
    return np.where(s == 0.0, 0.0, theta)
