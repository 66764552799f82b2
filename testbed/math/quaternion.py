"""Quaternion algebra in MuJoCo's convention: q = (w, x, y, z), Hamilton product.

`q` maps body-frame vectors to the world frame: v_world = q ∘ v_body ∘ q~. Every function but
`quat_to_matrix` also takes arrays of them with leading axes (..., 4) / (..., 3): one row per
world of a batch (testbed.batch).
"""

import math

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
    """Unit quaternion cos(angle/2) + axis sin(angle/2); `axis` must be a unit vector (..., 3),
    `angle` [rad] a number or an array (..., 1)."""
    axis = np.asarray(axis, dtype=float)
    half = np.asarray(angle, dtype=float) / 2
    return np.concatenate([np.cos(half) * np.ones_like(axis[..., :1]), np.sin(half) * axis], axis=-1)


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


def length(v):
    """|v| of (..., n) rows as (..., 1), or of one vector (n,) as a number: the square root of
    its dot product with itself, np.linalg.norm's (np.vecdot on rows rounds as np.dot does on
    one: a batch's row is its world's own to the bit)."""
    if v.ndim == 1:
        return math.sqrt(np.dot(v, v))
    return np.sqrt(np.vecdot(v, v))[..., None]


def length_column(v) -> np.ndarray:
    """|v| (`length`) as an array (..., 1): (1,) for one vector."""
    return np.reshape(length(v), np.shape(v)[:-1] + (1,))


def quat_from_rotation_vector(theta):
    """Unit quaternion exp(theta/2) = (cos |theta|/2, sin(|theta|/2) theta/|theta|) of a rotation
    vector [rad] (..., 3); (1, 0, 0, 0) for theta = 0."""
    theta = np.asarray(theta, dtype=float)
    angle = length(theta)
    if theta.ndim == 1:  # one vector: plain floats, a third of the rows' cost
        if angle == 0.0:
            return np.array([1.0, 0.0, 0.0, 0.0])
        half = angle / 2
        return np.concatenate([[np.cos(half)], np.sin(half) * (theta / angle)])
    axis = np.divide(theta, angle, out=np.zeros_like(theta), where=angle > 0)
    half = angle / 2
    return np.concatenate([np.cos(half), np.sin(half) * axis], axis=-1)


def rotation_vector(q):
    """theta = angle * axis of unit quaternion q (..., 4), the short way (angle in [0, pi]) [rad];
    zeros for the identity."""
    q = np.asarray(q, dtype=float)
    w, v = q[..., :1], q[..., 1:]
    s = length(v)
    if q.ndim == 1:  # one quaternion: plain floats, a third of the rows' cost
        if s == 0.0:
            return np.zeros(3)
        return (-2.0 if q[0] < 0 else 2.0) * np.arctan2(s, abs(q[0])) * v / s
    # -q is the same attitude: the one with w >= 0 turns the short way
    scale = np.where(w < 0, -2.0, 2.0) * np.arctan2(s, np.abs(w))
    return np.divide(scale * v, s, out=np.zeros_like(v), where=s > 0)
