"""Momentum envelope and singular surfaces of a cluster of single-gimbal CMGs.

Geometry of the 4-CMG "rhombus" cluster (SEEDS §004 eq. 15): CMG i has momentum
h (cos βi e_i + sin βi s_i z) with e1 = (cos α, sin α, 0), e2 = (-cos α, sin α, 0),
e3 = -e1, e4 = -e2, s = (+1, +1, -1, -1), gimbal axis g_i = s_i (e_i × z), so that
dh_i/dβi = g_i × h_i and the Jacobian ∂H/∂β (eq. 18) has columns g_i × h_i.

Singular states (Margulies & Aubrun 1978; Bedrossian 1990): J loses rank when every
torque axis g_i × h_i is perpendicular to one unit direction u. Then each h_i extremises
u·h_i on its gimbal circle, i.e. it is ± the projection of u onto the gimbal plane:

    h_i = ε_i h (g_i × u) × g_i / |g_i × u|,   ε_i = ±1,   H(u, ε) = Σ h_i.

ε = (+1, +1, +1, +1) maximises u·H: H(u, ε) over all u is the momentum envelope
(saturation surface). Any other sign pattern gives an internal singular surface. Since
H(-u, -ε) = H(u, ε), the patterns ε and -ε trace the same surface; we key surfaces by the
pattern with ε1 = +1 (8 surfaces, 1 external and 7 internal). Directions u within 1e-6
of a gimbal axis are dropped: there the projection vanishes and h_i is undetermined.

Only the gimbal axes enter the construction, so any cluster (any number m of units, e.g. the
three a failed unit leaves: remaining_cluster_surfaces) can be passed as an (m, 3)
array (e.g. read from the MuJoCo model); by default they come from α.

What the cluster can hold at all: momentum_gauge.py.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np

from testbed.systems.cmg_cluster.arrays import rhombus_axes
from testbed.systems.cmg_cluster.momentum_gauge import fibonacci_sphere, unit_axes
from testbed.errors import InputError
from testbed.math.validation import finite_number, positive_number

# Directions u closer than this (|g_i × u|) to a gimbal axis are skipped (see module doc).
_AXIS_EPS = 1e-6

EXTERNAL = (1, 1, 1, 1)


def rhombus_geometry(alpha):
    """(e, s, g) of the rhombus cluster (SEEDS §004 eq. 15): β = 0 directions e (4, 3),
    signs s (4,), gimbal axes g_i = s_i (e_i × z) (4, 3); from the domain's rhombus_axes."""
    e, g, sz = rhombus_axes(finite_number("cmg.alpha_rad", alpha))
    return e, sz[:, 2].copy(), g


def rhombus_gimbal_axes(alpha) -> np.ndarray:
    """Unit gimbal axes (4, 3) of the rhombus cluster for skew angle α [rad]."""
    return rhombus_geometry(alpha)[2]


def rotor_momenta(h, units: int) -> np.ndarray:
    """h_i [N m s] of `units` CMGs, (units,), from one h for all or one per unit; each > 0."""
    values = np.broadcast_to(np.asarray(h, dtype=float), (units,)) if np.ndim(h) == 0 else np.asarray(h, float)
    if values.shape != (units,):
        raise InputError("cmg.h_Nms", f"must be one rotor momentum or {units}, got {np.shape(h)}")
    return np.array([positive_number("cmg.h_Nms", value) for value in values])


def singular_momenta(u, signs, axes, h=1.0) -> np.ndarray:
    """Per-CMG momenta h_i = ε_i h_i (g_i × u) × g_i / |g_i × u| for directions u (m, 3):
    (m, n, 3); h: one rotor momentum for all units or one per unit [N m s].

    Every such state is singular, with u normal to all torque axes g_i × h_i.
    Raises InputError if some u lies along a gimbal axis (h_i undetermined there).
    """
    g = unit_axes(axes)
    u = np.atleast_2d(np.asarray(u, dtype=float))
    eps = np.asarray(signs, dtype=float).reshape(1, -1, 1)
    if eps.shape[1] != g.shape[0] or not np.all(np.abs(eps) == 1):
        raise InputError("envelope.signs", f"must be {g.shape[0]} values of +1 or -1, got {signs!r}")
    h = rotor_momenta(h, g.shape[0])[None, :, None]
    gxu = np.cross(g[None, :, :], u[:, None, :])  # (m, n, 3)
    norm = np.linalg.norm(gxu, axis=-1, keepdims=True)
    if np.any(norm < _AXIS_EPS):
        raise InputError("envelope.u", "a direction lies along a gimbal axis; its CMG momentum is undetermined")
    proj = np.cross(gxu, g[None, :, :])  # (g × u) × g: u projected onto the gimbal plane
    return eps * h * proj / norm


def _directions(axes, n):
    """Fibonacci directions with those along a gimbal axis removed."""
    u = fibonacci_sphere(n)
    near = np.linalg.norm(np.cross(axes[None, :, :], u[:, None, :]), axis=-1).min(axis=1)
    return u[near >= _AXIS_EPS]


def envelope_points(alpha, n, h=1.0, axes=None) -> np.ndarray:
    """Points (m, 3) [N m s] of the external momentum envelope (ε = +1) over n directions u."""
    g = rhombus_gimbal_axes(alpha) if axes is None else unit_axes(axes)
    return singular_momenta(_directions(g, n), (1,) * g.shape[0], g, h).sum(axis=1)


def singular_surface_points(alpha, n, h=1.0, axes=None) -> dict[tuple[int, ...], np.ndarray]:
    """{sign pattern ε (ε1 = +1): points (m, 3)} for the envelope (1,1,1,1) and the 7 internal surfaces."""
    g = rhombus_gimbal_axes(alpha) if axes is None else unit_axes(axes)
    # the per-CMG momenta of a pattern are those of the envelope times its signs ε_i (exact)
    external = singular_momenta(_directions(g, n), (1,) * g.shape[0], g, h)
    surfaces = {}
    for rest in itertools.product((1, -1), repeat=g.shape[0] - 1):
        pattern = (1, *rest)
        surfaces[pattern] = np.einsum("i,mia->ma", np.array(pattern, dtype=float), external)
    return surfaces


def remaining_cluster_surfaces(axes, failed, n, h=1.0) -> dict[tuple[int, ...], np.ndarray]:
    """The envelope and internal singular surfaces of the cluster left when the units `failed`
    (0-based) are dropped: the same construction on the remaining gimbal axes (any number of
    units; 2^(m-1) surfaces for m units). These are the momenta the remaining units can hold
    about the failed units' own, wherever those stopped."""
    g = unit_axes(axes)
    keep = [i for i in range(g.shape[0]) if i not in set(failed)]
    return singular_surface_points(None, n, rotor_momenta(h, g.shape[0])[keep], g[keep])


def surface_name(pattern) -> str:
    """"external" for the envelope, "internal/<p|m per sign>" for an internal singular surface."""
    if all(s > 0 for s in pattern):
        return "external"
    return "internal/" + "".join("p" if s > 0 else "m" for s in pattern)


def surface_color(pattern) -> tuple[int, int, int, int]:
    """RGBA of a surface: blue envelope; internal surfaces orange (odd number of -1) or magenta (even)."""
    if all(s > 0 for s in pattern):
        return (70, 130, 230, 255)
    return (230, 120, 40, 255) if sum(1 for s in pattern if s < 0) % 2 else (200, 40, 160, 255)


def write_envelope_rrd(path, alpha, h, n, axes=None) -> Path:
    """Write the envelope and internal singular surfaces as rr.Points3D (+ gimbal axes) to a .rrd file.

    Entities: envelope/external, envelope/internal/<pattern> (p = +1, m = -1), envelope/gimbal_axes.
    """
    # deferred: the geometry above does not need the viewer SDK
    from testbed.recording.rerun_sdk import rr
    from testbed.recording.trace import recording_to

    g = rhombus_gimbal_axes(alpha) if axes is None else unit_axes(axes)
    h = rotor_momenta(h, g.shape[0])
    surfaces = singular_surface_points(alpha, n, h, g)
    with recording_to(path, "testbed-envelope") as rec:
        radius = 0.01 * float(h.max())
        for pattern, points in surfaces.items():
            rec.log(f"envelope/{surface_name(pattern)}", rr.Points3D(points, colors=[surface_color(pattern)],
                                                                     radii=radius), static=True)
        rec.log(
            "envelope/gimbal_axes",
            rr.Arrows3D(vectors=2.0 * h[:, None] * g, labels=[f"g{i + 1}" for i in range(len(g))]),
            static=True,
        )
    return Path(path)
