"""What momentum a cluster of single-gimbal CMGs can hold, and what torque it can give.

What the cluster can hold at all (`envelope_gauge`). CMG i's momentum lies on a circle of radius
h_i in the plane normal to g_i, so every momentum the cluster holds lies in the Minkowski sum of
the disks bounded by those circles, a convex set with support function

    S(u) = Σ_i h_i |u × g_i|            (max of u·H over all gimbal angles; u·H(u, +1) = S(u)).

A momentum P with u·P > S(u) for some u is beyond every gimbal state; the gauge
max_u u·P / S(u) (<= 1: inside) measures by how much. For the rhombus the disks' sum IS the set
of momenta the cluster holds: g3 = g1 and g4 = g2, and two CMGs on one gimbal axis reach the
whole disk of radius 2h (two vectors of length h sum to any vector of length <= 2h), so the
envelope H(u, +1) is the boundary of that sum and the gauge is exact, not a bound
(tests/test_momentum_envelope.py holds it to the pair decomposition and to random gimbal angles).
The same construction bounds the torque: CMG i's torque h_i β'_i (g_i × ĥ_i) with |β'_i| <= β'max
lies in a disk of radius h_i β'max normal to g_i, so the torques of all gimbal states and rates
are β'max times the same convex set.
"""

from __future__ import annotations

import numpy as np

from testbed.errors import InputError
from testbed.math.validation import positive_count

# Directions sampled for the gauge before the best is refined (about 3 deg apart).
GAUGE_DIRECTIONS = 4000


def fibonacci_sphere(n) -> np.ndarray:
    """n nearly uniform unit vectors (n, 3) on the sphere (golden-angle spiral)."""
    n = positive_count("envelope.n_points", n)
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    r = np.sqrt(1.0 - z * z)
    phi = np.pi * (3.0 - np.sqrt(5.0)) * k
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


def envelope_support(u, axes, rotor_momenta) -> np.ndarray:
    """S(u) = Σ_i h_i |u × g_i| [N m s] for unit directions u (m, 3): the largest u·H the cluster
    can hold (module doc); `rotor_momenta` h_i (n,) or one h for all."""
    g = unit_axes(axes)
    return _support(np.atleast_2d(u), g, np.broadcast_to(np.asarray(rotor_momenta, dtype=float), (g.shape[0],)))


def _support(u, g, h) -> np.ndarray:
    """`envelope_support` for unit directions u (m, 3), validated unit axes g (n, 3) and h (n,):
    |u x g_i| from the cross product's components (np.cross's products, without its per-call
    cost: the gauge's search asks for S at every step)."""
    u = u[:, None, :]
    c0 = u[..., 1] * g[:, 2] - u[..., 2] * g[:, 1]
    c1 = u[..., 2] * g[:, 0] - u[..., 0] * g[:, 2]
    c2 = u[..., 0] * g[:, 1] - u[..., 1] * g[:, 0]
    return np.sqrt(c0 * c0 + c1 * c1 + c2 * c2) @ h


def envelope_gauge(momenta, axes, rotor_momenta, n=GAUGE_DIRECTIONS) -> tuple[np.ndarray, np.ndarray]:
    """(gauge, u) for momenta P (m, 3): gauge = max_u u·P / S(u) (<= 1: P inside the convex set
    of momenta the cluster's disks span, module doc) and the direction u attaining it (m, 3).

    Sampled over n Fibonacci directions and over ±g_i (where S has its kinks and the envelope its
    flat faces), each point's best direction of each set refined by a compass search on the sphere
    whose step halves from the sampling's spacing to 1e-7 rad (the gauge's error then ~1e-9 where
    the maximum is smooth; up to ~1e-5 where it lies in a narrow wedge next to a kink ±g_i).
    Every u gives a lower bound, so a gauge above 1 is certain: P lies beyond the plane
    u·H = S(u), which no gimbal state crosses."""
    g = unit_axes(axes)
    h = np.broadcast_to(np.asarray(rotor_momenta, dtype=float), (g.shape[0],))
    P = np.atleast_2d(np.asarray(momenta, dtype=float))

    def ratio(u):   # u·P / S(u) for one direction per point, u (m, 3) unit
        return np.einsum("ij,ij->i", u, P) / _support(u, g, h)

    sampled = [fibonacci_sphere(n), np.concatenate([g, -g])]
    results = [_compass_search(ratio, *_best_sampled(P, u, g, h), np.sqrt(4.0 * np.pi / n))
               for u in sampled]
    # the best of two searches: from the best smooth sample and from the best kink ±g_i (a
    # maximum near a kink lies in a narrow wedge the search from the kink may miss)
    take_first = results[0][0] >= results[1][0]
    gauge = np.where(take_first, results[0][0], results[1][0])
    direction = np.where(take_first[:, None], results[0][1], results[1][1])
    return gauge, direction


def support_extremes(axes, rotor_momenta, n=GAUGE_DIRECTIONS, starts=8):
    """((least S, u), (largest S, u)) of the support S(u) = Σ_i h_i |u × g_i| [N m s] over all unit
    directions u: the least and most momentum the cluster holds in any direction. Sampled over n
    Fibonacci directions and ±g_i (S has its cusps there, where minima often lie); the `starts`
    best samples of each are refined by the compass search (`envelope_gauge`'s), whose step ends
    at 1e-7 rad, and the best result kept."""
    g = unit_axes(axes)
    h = np.broadcast_to(np.asarray(rotor_momenta, dtype=float), (g.shape[0],))
    candidates = np.concatenate([fibonacci_sphere(n), g, -g])
    extremes = []
    for sign in (-1.0, 1.0):  # -S: the least; +S: the largest
        def signed(u, sign=sign):
            return sign * _support(u, g, h)
        values = signed(candidates)
        best = np.argsort(values)[-starts:]
        found, directions = _compass_search(signed, values[best], candidates[best], np.sqrt(4.0 * np.pi / n))
        k = int(np.argmax(found))
        extremes.append((float(sign * found[k]), directions[k]))
    return extremes[0], extremes[1]


def _best_sampled(P, u, g, h):
    """(ratio, direction) of the sampled directions u (k, 3) with the largest u·P / S(u), per point."""
    ratios = (P @ u.T) / _support(u, g, h)
    best = np.argmax(ratios, axis=1)
    return ratios[np.arange(len(P)), best], u[best]


def _compass_search(ratio, value, direction, step, rounds=2, headings=16):
    """Raise ratio(u) per point from (value, direction): try `headings` steps in the tangent plane,
    keep what improves, halve the step after `rounds` passes, down to 1e-7 rad."""
    angles = np.linspace(0.0, 2.0 * np.pi, headings, endpoint=False)
    while step > 1e-7:
        for _ in range(rounds):
            helper = np.where(np.abs(direction[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
            e1 = np.cross(direction, helper)
            e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
            e2 = np.cross(direction, e1)
            for a in angles:
                trial = direction + step * (np.cos(a) * e1 + np.sin(a) * e2)
                trial /= np.linalg.norm(trial, axis=1, keepdims=True)
                trial_value = ratio(trial)
                better = trial_value > value
                value = np.where(better, trial_value, value)
                direction = np.where(better[:, None], trial, direction)
        step /= 2.0
    return value, direction


def unit_axes(axes) -> np.ndarray:
    """The gimbal axes as a validated (n, 3) array of unit vectors (InputError otherwise)."""
    g = np.asarray(axes, dtype=float)
    if g.ndim != 2 or g.shape[1] != 3 or g.shape[0] < 1 or not np.all(np.isfinite(g)):
        raise InputError("cmg.gimbal_axes", f"must be an (n, 3) array of finite numbers, got shape {g.shape}")
    norms = np.linalg.norm(g, axis=1)
    if np.any(np.abs(norms - 1.0) > 1e-6):
        raise InputError("cmg.gimbal_axes", f"must be unit vectors, norms {np.round(norms, 9).tolist()}")
    return g / norms[:, None]
