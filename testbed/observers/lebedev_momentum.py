"""Which total angular momenta one gyro can observe a spinning CMG spacecraft with.

Our extension of Lebedev (1976) to a body whose actuators hold momentum H (README "Non-zero
total momentum"). With H the observer error obeys e' = (A_H - l C) e, A_H = A + I^-1 [H x]
(testbed.observers.lebedev_observer.gyrostat_error_matrix), so the gain exists iff the pair
(A_H, C) is observable: det W(A_H) != 0, W = [C; C A_H; C A_H^2] (eq. 4.4 with A -> A_H).

At the wanted spin w = (0, 0, Omega) the total momentum in body axes is L = I Omega e_z + H,
and A_H depends on H only through L: its 2x2 block is [[0, (Iy Omega - L3)/Ix],
[(L3 - Ix Omega)/Iy, 0]] (the rigid body's A with Iz Omega replaced by L3), its other entries
L1, L2 over the moments. Expanding det W symbolically for L along z gives (checked against
numerical determinants on random bodies in tests/test_lebedev_momentum.py)

    det W = gamma (Ix Omega - L3)(Iy Omega - L3)(Ix (Ix Omega - L3) beta^2 + Iy (Iy Omega - L3) alpha^2) / (Ix^2 Iy^2),

which for H = 0 (L3 = Iz Omega) is eq. 4.5. So an axial total momentum is unobservable at
L3 = Ix Omega, at L3 = Iy Omega and at L3 = Omega (Ix^2 beta^2 + Iy^2 alpha^2) / (Ix beta^2 + Iy alpha^2)
between them (`axial_unobservable_momenta`). In general det W is a cubic in L; its zero set is
a surface through those three points. L is fixed in inertial space while the body turns under
it: whatever attitude the spin-up ends in, every end state is observable iff the ball |L| < r*
misses the surface, r* = `observable_momentum_radius` (the nearest zero of the cubic along any
ray from L = 0, which is observable whenever the rigid body is); r* is small (15.4 N m s for the
flagship's spacecraft, below Ix Omega = 21.8) because the surface bends towards L = 0 off the
z axis. The spin-up does not end in any attitude, though: L keeps its length and, nearly, its
angle to the spin axis, and at the end its transverse part turns with the body, sweeping a
circle. `check_momentum_observable` therefore asks for a margin det W(L) / det W(0) >= MIN_MARGIN
on the circles within END_BAND_DEG of L's initial angle to z (`end_state_margin`); the
measured tilt of the shipped scenario is in the README.
"""

from __future__ import annotations

import numpy as np

from testbed.errors import InputError
from testbed.observers.lebedev_observer import gyrostat_error_matrix

DIRECTIONS = 96   # polar angles of the direction grid (twice as many azimuths) for r*
END_BAND_DEG = 15.0   # how far the spin-up may tilt the spin axis against L (measured: README)
MIN_MARGIN = 0.1      # least det W / det W(L = 0) accepted: the gain grows about as its inverse


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


def end_state_margin(inertia, spin_rate, sensor_axis, total_momentum, band_deg: float = END_BAND_DEG):
    """(m, L_worst): the least observability margin det W(L) / det W(0) over the end states of a
    spin with total momentum `total_momentum` (body axes at t = 0), and the state where it is least.

    At the end L keeps its length and its angle to the spin axis z while its transverse part turns
    with the body: a circle. The spin-up may tilt the spin axis against L, so the circles within
    `band_deg` of L's initial angle to z are all searched (module doc)."""
    L = np.asarray(total_momentum, float)
    size = float(np.linalg.norm(L))
    polar0 = np.arccos(np.clip(L[2] / size, -1.0, 1.0))
    band = np.radians(band_deg)
    polar = np.linspace(max(0.0, polar0 - band), min(np.pi, polar0 + band), 31)
    azimuth = np.linspace(0.0, 2 * np.pi, 360, endpoint=False)
    p, a = np.meshgrid(polar, azimuth)
    states = size * np.stack([np.sin(p) * np.cos(a), np.sin(p) * np.sin(a), np.cos(p)], -1).reshape(-1, 3)
    margins = (observability_determinant(inertia, spin_rate, sensor_axis, states)
               / observability_determinant(inertia, spin_rate, sensor_axis, np.zeros(3)))
    i = int(np.argmin(margins))
    return float(margins[i]), states[i]


def check_momentum_observable(inertia, spin_rate, sensor_axis, total_momentum, field: str) -> None:
    """Refuse a total momentum whose end states one gyro observes with a margin below MIN_MARGIN."""
    if float(np.linalg.norm(total_momentum)) == 0.0:
        return
    margin, worst = end_state_margin(inertia, spin_rate, sensor_axis, total_momentum)
    if margin < MIN_MARGIN:
        size = float(np.linalg.norm(total_momentum))
        raise InputError(field, f"total angular momentum L = {np.array2string(np.asarray(total_momentum), precision=4)} "
                                f"N m s: one gyro cannot observe the spin it ends in (det W / det W(L = 0) = "
                                f"{margin:.3g} < {MIN_MARGIN} at L = {np.array2string(worst, precision=3)}, "
                                f"|L| = {size:.4g})")
