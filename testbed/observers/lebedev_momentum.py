"""Which total angular momenta one gyro can observe a spinning CMG spacecraft with.

Our extension of Lebedev (1976) to a body whose actuators hold momentum H (README "Non-zero
total momentum"). With H the observer error obeys e' = (A_H - l C) e, A_H = A + I^-1 [H x]
(testbed.observers.lebedev_observer.gyrostat_error_matrix), so the gain exists iff the pair
(A_H, C) is observable: det W(A_H) != 0, W = [C; C A_H; C A_H^2] (eq. 4.4 with A -> A_H).

At the wanted spin w = (0, 0, Omega) the total momentum in body axes is L = I Omega e_z + H,
and A_H depends on H only through L: its 2x2 block is [[0, (Iy Omega - L3)/Ix],
[(L3 - Ix Omega)/Iy, 0]] (the rigid body's A with Iz Omega replaced by L3), its other entries
L1, L2 over the moments. Expanding det W (done symbolically; the numbers below check it) for L
along z gives

    det W = gamma (Ix Omega - L3)(Iy Omega - L3)(Ix (Ix Omega - L3) beta^2 + Iy (Iy Omega - L3) alpha^2) / (Ix^2 Iy^2),

which for H = 0 (L3 = Iz Omega) is eq. 4.5. So an axial total momentum is unobservable at
L3 = Ix Omega, at L3 = Iy Omega and at L3 = Omega (Ix^2 beta^2 + Iy^2 alpha^2) / (Ix beta^2 + Iy alpha^2)
between them (`axial_unobservable_momenta`). In general det W is a cubic in L; its zero set is
a surface through those three points. L is fixed in inertial space while the body turns under
it, so the spin-up may end with L in any body direction: every end state is observable iff the
ball |L| < r* misses the surface, r* = `observable_momentum_radius` (the nearest zero of the
cubic along any ray from L = 0, which is observable whenever the rigid body is).
"""

from __future__ import annotations

import numpy as np

from testbed.errors import InputError
from testbed.observers.lebedev_observer import gyrostat_error_matrix

DIRECTIONS = 96   # polar angles of the direction grid (twice as many azimuths) for r*


def observability_determinant(inertia, spin_rate, sensor_axis, total_momentum):
    """det [C; C A_H; C A_H^2] with H = L - I Omega e_z, for one L (3,) or a stack (N, 3)."""
    inertia = np.asarray(inertia, float)
    L = np.asarray(total_momentum, float)
    H = L - np.array([0.0, 0.0, inertia[2] * spin_rate])
    A_H = gyrostat_error_matrix(inertia, spin_rate, H)
    c = np.asarray(sensor_axis, float)
    row1 = np.einsum("j,...jk->...k", c, A_H)
    row2 = np.einsum("...j,...jk->...k", row1, A_H)
    return np.linalg.det(np.stack([np.broadcast_to(c, row1.shape), row1, row2], -2))


def axial_unobservable_momenta(inertia, spin_rate, sensor_axis) -> np.ndarray:
    """The three L3 [N m s] at which a total momentum along z is unobservable (module doc)."""
    ix, iy, _ = np.asarray(inertia, float)
    alpha, beta, _ = np.asarray(sensor_axis, float)
    w = float(spin_rate)
    weighted = w * (ix**2 * beta**2 + iy**2 * alpha**2) / (ix * beta**2 + iy * alpha**2)
    return np.array([ix * w, iy * w, weighted])


def _directions(n: int = DIRECTIONS) -> np.ndarray:
    polar = (np.arange(n) + 0.5) * np.pi / n
    azimuth = np.arange(2 * n) * np.pi / n
    p, a = np.meshgrid(polar, azimuth)
    return np.stack([np.sin(p) * np.cos(a), np.sin(p) * np.sin(a), np.cos(p)], -1).reshape(-1, 3)


def observable_momentum_radius(inertia, spin_rate, sensor_axis, n: int = DIRECTIONS):
    """(r*, L*): the largest |L| [N m s] whose whole ball one gyro observes, and the nearest
    unobservable total momentum L* (body axes). det W along a ray L = s u is a cubic in s,
    fitted exactly through four samples; r* is the least positive real root over a grid of
    directions u (2 n^2 of them)."""
    inertia = np.asarray(inertia, float)
    u = _directions(n)
    scale = float(np.max(inertia) * abs(spin_rate))
    samples = np.stack([observability_determinant(inertia, spin_rate, sensor_axis, s * scale * u)
                        for s in range(4)], -1)
    c3, c2, c1, c0 = np.linalg.solve(np.vander(np.arange(4.0), 4), samples.T)   # per direction
    # roots of each cubic: eigenvalues of its companion matrix (a cubic that degenerates to a
    # lower degree along a direction has fewer roots there; those directions are skipped)
    proper = np.abs(c3) > 1e-12 * np.max(np.abs([c3, c2, c1, c0]), axis=0)
    companion = np.zeros((int(proper.sum()), 3, 3))
    companion[:, 0, :] = -np.stack([c2, c1, c0], -1)[proper] / c3[proper, None]
    companion[:, 1, 0] = companion[:, 2, 1] = 1.0
    roots = np.linalg.eigvals(companion)
    real = (np.abs(roots.imag) <= 1e-9 * np.maximum(1.0, np.abs(roots))) & (roots.real > 0)
    first = np.where(real, roots.real, np.inf).min(axis=1)
    i = int(np.argmin(first))
    if not np.isfinite(first[i]):
        return np.inf, None
    return float(first[i]) * scale, float(first[i]) * scale * u[proper][i]


def check_momentum_observable(inertia, spin_rate, sensor_axis, total_momentum, field: str) -> None:
    """Refuse a total momentum |L| whose ball reaches an unobservable state (module doc)."""
    size = float(np.linalg.norm(total_momentum))
    if size == 0.0:
        return
    radius, nearest = observable_momentum_radius(inertia, spin_rate, sensor_axis)
    if size >= radius:
        raise InputError(field, f"total angular momentum |L| = {size:.4g} N m s: one gyro cannot observe the spin "
                                f"for every attitude it may end in (det W = 0 at L = "
                                f"{np.array2string(nearest, precision=3)} N m s; needs |L| < {radius:.4g})")
