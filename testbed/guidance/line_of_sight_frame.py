"""The frame that looks along a moving line of sight: z along the line of sight u = ρ/|ρ|, y along
the part of a secondary direction d normal to u, x = y × z; and its angular velocity and
acceleration in its own axes, exact from the first two derivatives of ρ and d.

Each vector is carried with its first two time derivatives (a second-order jet), so the frame's
axes come with theirs; with Ṙ = R [ω×] the rates are ω = (ẏ·z, ż·x, ẋ·y) and, differentiating
these (the frame components of ω̇ are those of the world vector), ω̇ = (ÿ·z + ẏ·ż, z̈·x + ż·ẋ,
ẍ·y + ẋ·ẏ) (docs/theory/environment.md, "Ground targets")."""

from __future__ import annotations

import math

import numpy as np


def _dot(a, b):
    """(a·b, its first and second derivatives) of jets a, b."""
    return (a[0] @ b[0], a[1] @ b[0] + a[0] @ b[1], a[2] @ b[0] + 2.0 * (a[1] @ b[1]) + a[0] @ b[2])


def _cross(a, b):
    """The jet of a × b."""
    return (np.cross(a[0], b[0]), np.cross(a[1], b[0]) + np.cross(a[0], b[1]),
            np.cross(a[2], b[0]) + 2.0 * np.cross(a[1], b[1]) + np.cross(a[0], b[2]))


def _unit(a):
    """The jet of u = a/|a|: with n = |a|, ṅ = u·ȧ, n̈ = u̇·ȧ + u·ä,
    u̇ = (ȧ - u ṅ)/n and ü = (ä - 2 u̇ ṅ - u n̈)/n."""
    n = math.sqrt(a[0] @ a[0])
    u = a[0] / n
    n1 = u @ a[1]
    u1 = (a[1] - u * n1) / n
    n2 = u1 @ a[1] + u @ a[2]
    return u, u1, (a[2] - 2.0 * u1 * n1 - u * n2) / n


def look_frame(line_of_sight, secondary):
    """(R, ω, ω̇) of the frame of the module doc: R has the axes x, y, z as its columns (frame to
    world), ω [rad/s] and ω̇ [rad/s²] are in frame axes. Each argument is a jet
    (value, first, second derivative) of world vectors; `secondary` must not be parallel to the
    line of sight (the frame is undefined there)."""
    z = _unit(line_of_sight)
    along = _dot(secondary, z)
    normal = tuple(d - sum(math.comb(k, j) * along[j] * z[k - j] for j in range(k + 1))
                   for k, d in enumerate(secondary))   # d - (d·z) z by Leibniz's rule
    y = _unit(normal)
    x = _cross(y, z)
    rate = np.array([y[1] @ z[0], z[1] @ x[0], x[1] @ y[0]])
    acceleration = np.array([y[2] @ z[0] + y[1] @ z[1], z[2] @ x[0] + z[1] @ x[1], x[2] @ y[0] + x[1] @ y[1]])
    return np.column_stack([x[0], y[0], z[0]]), rate, acceleration
