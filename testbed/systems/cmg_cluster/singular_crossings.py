"""Where a cluster's singular surfaces cross a line through the origin, and the gimbal state there.

A singular surface of sign pattern ε is H(u, ε) = Σ ε_i h_i (g_i × u) × g_i / |g_i × u| over unit
directions u (momentum_envelope.singular_momenta; Kurokawa 2007, J. Guid. Control Dyn. 30(5),
section II). It meets the ray t d (t > 0) where the two components of H(u, ε) normal to d vanish:
two equations in the two angles of u, solved from many starting directions (SciPy's `root`).
A crossing is isolated when those two equations are transversal there (their 2 x 2 Jacobian in the
plane tangent to the sphere at u is regular); where a surface holds a whole segment of the ray (a
degenerate set) the Jacobian is singular and the solutions spread along the segment. The gimbal
angles of a singular state follow from its per-unit momenta (`gimbal_angles`), so the compiled
model can check it (H and sqrt det J J^T).
Results: docs/theory/momentum-envelope.md ("Singular surfaces of the pyramid and the box").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.systems.cmg_cluster.momentum_envelope import singular_momenta
from testbed.systems.cmg_cluster.momentum_gauge import fibonacci_sphere, unit_axes

CONVERGED = 1e-11     # |H normal to d| / h_max at an accepted solution (the solver reaches ~1e-15)
SAME_POINT = 1e-7     # two solutions whose t differ by less (share of h_max) are one crossing
TRANSVERSAL = 1e-5    # least singular value of the 2 x 2 Jacobian [h_max / rad] of an isolated crossing
AXIS_CLEARANCE = 1e-4  # u this close to a gimbal axis (|g_i x u|) is no solution: h_i undetermined


@dataclass(frozen=True)
class Crossing:
    """A singular state on the ray: distance t [N m s] along d, singular direction u (3,),
    per-unit momenta (n, 3) [N m s]; isolated: the surface meets the ray there in a point (module doc)."""

    distance: float
    direction: np.ndarray
    unit_momenta: np.ndarray
    isolated: bool


def _unit(theta: float, phi: float) -> np.ndarray:
    return np.array([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)])


def ray_crossings(direction, pattern, axes, h=1.0, starts: int = 400) -> list[Crossing]:
    """The crossings of the singular surface of sign pattern ε (`pattern`, n values of +-1) with the
    ray t d, t > 0 (d: `direction`, any length), of the cluster with gimbal axes (n, 3) and rotor
    momenta h [N m s]; one Crossing per distinct t, nearest first. `starts`: Fibonacci starting
    directions for the solver (a degenerate segment shows as many crossings along it)."""
    g = unit_axes(axes)
    d = np.asarray(direction, dtype=float)
    d = d / np.linalg.norm(d)
    a = np.cross(d, [0.3, 0.5, 0.7] if abs(d[2]) < 0.9 else [1.0, 0.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(d, a)
    h_max = float(np.max(np.broadcast_to(np.asarray(h, float), (len(g),))))

    def normal_part(u):
        """The components of H(u, e) normal to d [h_max]; inf on a gimbal axis (h_i undetermined)."""
        if np.linalg.norm(np.cross(g, u), axis=1).min() < AXIS_CLEARANCE:
            return np.array([np.inf, np.inf])
        H = singular_momenta(u, pattern, g, h)[0].sum(axis=0)
        return np.array([H @ a, H @ b]) / h_max

    from scipy.optimize import root  # on use: at the top it would cost every command start-up time

    found: list[Crossing] = []
    for u0 in fibonacci_sphere(starts):
        x0 = [np.arccos(np.clip(u0[2], -1.0, 1.0)), np.arctan2(u0[1], u0[0])]
        solution = root(lambda x: normal_part(_unit(*x)), x0, tol=1e-14)
        u = _unit(*solution.x)
        if not np.linalg.norm(normal_part(u)) <= CONVERGED:  # also inf: on a gimbal axis
            continue
        momenta = singular_momenta(u, pattern, g, h)[0]
        t = float(momenta.sum(axis=0) @ d)
        if t > SAME_POINT * h_max and all(abs(t - c.distance) > SAME_POINT * h_max for c in found):
            found.append(Crossing(t, u, momenta, _transversal(normal_part, u)))
    return sorted(found, key=lambda c: c.distance)


def _transversal(normal_part, u) -> bool:
    """Whether the 2 x 2 Jacobian of normal_part at u, in coordinates of the plane tangent to the
    sphere at u (no pole there, unlike the angles), is regular (central differences, step 1e-6:
    truncation ~1e-12, rounding ~1e-10 against TRANSVERSAL = 1e-5)."""
    e1 = np.cross(u, [1.0, 0.0, 0.0] if abs(u[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    step = 1e-6

    def moved(v):
        return normal_part((u + v) / np.linalg.norm(u + v))

    jacobian = np.column_stack([(moved(step * e) - moved(-step * e)) / (2 * step) for e in (e1, e2)])
    return bool(np.all(np.isfinite(jacobian))) and np.linalg.svd(jacobian, compute_uv=False)[-1] > TRANSVERSAL


def gimbal_angles(unit_momenta, spin_axes_zero, turn_axes) -> np.ndarray:
    """Gimbal angles b_i [rad] (n,) at which each unit's momentum points along unit_momenta[i]:
    atan2(h_i . t_i, h_i . e_i), e_i the spin axis at b = 0 and t_i = g_i x e_i (ClusterGeometry)."""
    m = np.asarray(unit_momenta, dtype=float)
    return np.arctan2(np.einsum("ia,ia->i", m, turn_axes), np.einsum("ia,ia->i", m, spin_axes_zero))
