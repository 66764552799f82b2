"""Where the pyramid's and the box's singular surfaces cross the x and z axes
(testbed/systems/cmg_cluster/singular_crossings.py; docs/theory/momentum-envelope.md, "Singular
surfaces of the pyramid and the box"): each crossing the root finder gives is checked against a
closed form, against the compiled model (H and sqrt det J J^T at the gimbal angles it gives) and
typed by Bedrossian's test, on the published skews and on one that is not (40 deg)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from testbed.steering.singularity_type import DEGENERATE, ELLIPTIC, HYPERBOLIC, singularity_type
from testbed.systems.cmg_cluster.envelope_command import cluster_of_array
from testbed.systems.cmg_cluster.singular_crossings import gimbal_angles, ray_crossings

X, Z = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])
STARTS = 150  # solver starts per surface: every crossing below is found from many of them


def on_model(geometry, crossing, axis):
    """The crossing's gimbal state on the compiled model: (H / h, sqrt det J J^T, Bedrossian's kind)."""
    beta = gimbal_angles(crossing.unit_momenta, geometry.spin_axes_zero, geometry.turn_axes)
    H = geometry.momentum(beta)
    kind = singularity_type(geometry.unit_jacobian(beta), geometry.unit_jacobian_derivative(beta), H).kind
    return H, geometry.singularity_measure(beta), kind


def crossings(geometry, axis, pattern):
    return [c for c in ray_crossings(axis, pattern, geometry.gimbal_axes, 1.0, STARTS) if c.isolated]


@pytest.mark.parametrize("skew_deg", [math.degrees(math.acos(1 / math.sqrt(3))), 53.13010235415598, 40.0])
def test_pyramid_axis_crossings_are_the_closed_forms(skew_deg):
    """Along x (u = x by symmetry): the envelope at 2h(1 + cos b), elliptic; the surface with one
    unit turned against u at 2h cos b (the state (-90, 0, 90, 0) deg: elliptic, no null motion
    leaves it) and, beside it, a hyperbolic crossing with u off the axis (no closed form; 1.1405 h
    at 54.74 deg); the surface (+, -, +, -) at 2h(1 - cos b), hyperbolic. Along z: the envelope at 4h sin b,
    elliptic; one unit against u at 2h sin^2 b, hyperbolic (found by the solver at every skew, a
    closed form we fitted, not derived). The compiled model puts each gimbal state on the axis at
    that distance to 1e-12 h with sqrt det J J^T below 1e-6 (the solver's u is good to ~1e-8)."""
    skew = math.radians(skew_deg)
    g = cluster_of_array("pyramid", None, skew_deg, 1.0)
    c, s = math.cos(skew), math.sin(skew)
    expected = {  # (axis, pattern): [(distance / h, kind) of each isolated crossing, nearest first]
        ("x", (1, 1, 1, 1)): [(2 * (1 + c), ELLIPTIC)],
        ("x", (1, -1, 1, 1)): [(None, HYPERBOLIC), (2 * c, ELLIPTIC)],
        ("x", (1, -1, 1, -1)): [(2 * (1 - c), HYPERBOLIC)],
        ("z", (1, 1, 1, 1)): [(4 * s, ELLIPTIC)],
        ("z", (1, -1, 1, 1)): [(2 * s * s, HYPERBOLIC)],
    }
    for (name, pattern), wanted in expected.items():
        axis = X if name == "x" else Z
        found = crossings(g, axis, pattern)
        if name == "x" and pattern == (1, -1, 1, -1):
            found = [f for f in found if f.distance > 1e-3]  # the H = 0 singular state is not a crossing
        assert len(found) == len(wanted), (name, pattern, [f.distance for f in found])
        for crossing, (distance, kind) in zip(found, wanted):
            if distance is not None:
                assert crossing.distance == pytest.approx(distance, abs=1e-9), (name, pattern)
            else:
                assert 0.9 * 2 * c < crossing.distance < 2 * c, (name, pattern, crossing.distance)
            H, measure, got = on_model(g, crossing, axis)
            np.testing.assert_allclose(H, crossing.distance * axis, rtol=0, atol=1e-12)
            assert measure < 1e-6, (name, pattern, measure)
            assert got == kind, (name, pattern, got)


def test_box_axis_crossings():
    """The box (b = 90 deg: gimbal axes in the xy plane): along z the envelope at 4h (every spin
    axis along z, elliptic, a point crossing) and the surface with one unit against u at 2h, which
    meets the axis along a set (not transversally) in Bedrossian's degenerate state (null motion
    moves along the singular set); along x, where two gimbal axes lie, 2h = 2h(1 + cos 90 deg)."""
    g = cluster_of_array("box", None, None, 1.0)
    (top,) = crossings(g, Z, (1, 1, 1, 1))
    assert top.distance == pytest.approx(4.0, abs=1e-9) and on_model(g, top, Z)[2] == ELLIPTIC
    inner = [c for c in ray_crossings(Z, (1, 1, 1, -1), g.gimbal_axes, 1.0, STARTS) if abs(c.distance - 2) < 1e-9]
    assert inner and not any(c.isolated for c in inner)
    for crossing in inner:
        H, measure, kind = on_model(g, crossing, Z)
        assert kind == DEGENERATE and measure < 1e-6
        np.testing.assert_allclose(H, [0.0, 0.0, 2.0], rtol=0, atol=1e-12)
    side = ray_crossings(X, (1, -1, -1, -1), g.gimbal_axes, 1.0, STARTS)
    assert side and all(abs(c.distance - 2.0) < 1e-9 and on_model(g, c, X)[1] < 1e-6 for c in side)
