"""Momentum envelope and singular surfaces of the 4-CMG rhombus (SEEDS §004 eq. 15, 18),
checked against eq. (15) written out term by term and its analytic Jacobian."""

import numpy as np
import pytest

from testbed.errors import InputError
from testbed.systems.cmg_cluster.momentum_envelope import (
    EXTERNAL,
    envelope_points,
    fibonacci_sphere,
    rhombus_geometry,
    rhombus_gimbal_axes,
    singular_momenta,
    singular_surface_points,
    write_envelope_rrd,
)
from testbed.systems.cmg_cluster.momentum_gauge import envelope_gauge, envelope_support

ALPHAS = [np.radians(30.0), np.radians(45.0), np.radians(60.0), 1.2]


def _H_eq15(beta, alpha, h):
    """Total momentum, SEEDS §004 eq. (15), as printed; beta (..., 4) -> (..., 3)."""
    c, s = np.cos(beta).T, np.sin(beta).T
    return h * np.stack([
        np.cos(alpha) * (c[0] - c[1] - c[2] + c[3]),
        np.sin(alpha) * (c[0] + c[1] - c[2] - c[3]),
        s[0] + s[1] - s[2] - s[3],
    ], axis=-1)


def _J_eq15(beta, alpha, h):
    """∂H/∂β of eq. (15) differentiated by hand (eq. 18 with the cos α, sin α factors); (..., 3, 4)."""
    c, s = np.cos(beta), np.sin(beta)
    sign_x, sign_y, sign_z = np.array([-1, 1, 1, -1]), np.array([-1, -1, 1, 1]), np.array([1, 1, -1, -1])
    return h * np.stack([np.cos(alpha) * sign_x * s, np.sin(alpha) * sign_y * s, sign_z * c], axis=-2)


def _beta_from_momenta(hi, alpha, h):
    """Recover βi from h_i = h (cos βi e_i + sin βi s_i z), checking h_i lies on its gimbal circle."""
    e, s, _ = rhombus_geometry(alpha)
    z = np.array([0.0, 0.0, 1.0])
    beta = np.arctan2(hi @ z * s, np.einsum("mij,ij->mi", hi, e))
    rebuilt = h * (np.cos(beta)[..., None] * e + (np.sin(beta) * s)[..., None] * z)
    np.testing.assert_allclose(rebuilt, hi, atol=1e-12 * h)
    return beta


@pytest.mark.parametrize("alpha", ALPHAS)
def test_envelope_extent_along_the_axes(alpha):
    h = 2.5
    g = rhombus_gimbal_axes(alpha)
    ex, ey, ez = np.eye(3)
    expected = {0: 4 * h * np.cos(alpha), 1: 4 * h * np.sin(alpha), 2: 4 * h}
    # Exact: the envelope point for u = ±x, ±y, ±z.
    for k, u in enumerate((ex, ey, ez)):
        for sign in (1.0, -1.0):
            H = singular_momenta(sign * u, EXTERNAL, g, h).sum(axis=1)[0]
            np.testing.assert_allclose(H, sign * expected[k] * u, atol=1e-12)
    # Sampled: the support function max over the grid never exceeds the extent and reaches it
    # to the grid's resolution.
    pts = envelope_points(alpha, 20000, h)
    for k in range(3):
        top = np.abs(pts[:, k]).max()
        assert top <= expected[k] * (1 + 1e-12)
        assert top >= expected[k] * (1 - 1e-4)


@pytest.mark.parametrize("alpha", [np.radians(45.0), 1.2])
def test_every_singular_surface_point_is_singular(alpha):
    h = 1.0
    g = rhombus_gimbal_axes(alpha)
    u = fibonacci_sphere(600)
    u = u[np.linalg.norm(np.cross(g[None], u[:, None]), axis=-1).min(axis=1) >= 1e-6]
    surfaces = singular_surface_points(alpha, 600, h)
    assert len(surfaces) == 8 and EXTERNAL in surfaces
    for pattern, points in surfaces.items():
        hi = singular_momenta(u, pattern, g, h)
        np.testing.assert_allclose(points, hi.sum(axis=1), atol=1e-15)
        beta = _beta_from_momenta(hi, alpha, h)
        np.testing.assert_allclose(_H_eq15(beta, alpha, h), points, atol=1e-12)
        J = _J_eq15(beta, alpha, h)
        # Rank 2: the smallest singular value vanishes (SVD resolves it to ~eps; the product
        # σ1σ2σ3 = sqrt(det J Jᵀ) only to ~sqrt(eps) through det's rounding), and u spans
        # the left null space of J.
        sigma = np.linalg.svd(J, compute_uv=False)
        assert sigma[:, -1].max() < 1e-12
        assert np.prod(sigma, axis=1).max() < 1e-11
        assert np.abs(np.einsum("mi,mij->mj", u, J)).max() < 1e-12
    # The test's Jacobian does detect rank: β = (45°, -45°, -45°, 45°) is H = 0 at full rank.
    b = np.radians([45.0, -45.0, -45.0, 45.0])
    np.testing.assert_allclose(_H_eq15(b, alpha, h), 0.0, atol=1e-15)
    assert np.sqrt(np.linalg.det(_J_eq15(b, alpha, h) @ _J_eq15(b, alpha, h).T)) > 0.1


def test_envelope_is_the_outermost_singular_surface_and_u_is_its_normal():
    """u·H(u, +) = Σ|P_i u| is the support function: no singular point of any pattern exceeds it."""
    alpha, h = np.radians(50.0), 1.0
    g = rhombus_gimbal_axes(alpha)
    u = fibonacci_sphere(400)
    support = singular_momenta(u, EXTERNAL, g, h).sum(axis=1)
    all_points = np.vstack(list(singular_surface_points(alpha, 400, h).values()))
    assert np.all(all_points @ u.T <= np.einsum("ij,ij->i", support, u)[None, :] + 1e-12)
    # ε and -ε trace the same surface: H(-u, -ε) = H(u, ε).
    pattern = (1, -1, 1, -1)
    np.testing.assert_allclose(singular_momenta(-u, [-s for s in pattern], g, h).sum(axis=1),
                               singular_momenta(u, pattern, g, h).sum(axis=1), atol=1e-15)


def test_gimbal_axes_can_be_passed_in():
    alpha = 0.7
    g = rhombus_gimbal_axes(alpha)
    np.testing.assert_allclose(envelope_points(alpha, 500, 1.0, axes=g), envelope_points(alpha, 500))
    # Only the axes matter: reversing an axis (g -> -g) leaves the gimbal plane and the envelope alone.
    flipped = g * np.array([1.0, -1.0, 1.0, -1.0])[:, None]
    np.testing.assert_allclose(envelope_points(alpha, 500, 1.0, axes=flipped), envelope_points(alpha, 500),
                               atol=1e-12)
    with pytest.raises(InputError) as e:
        envelope_points(alpha, 500, 1.0, axes=2 * g)
    assert e.value.field == "cmg.gimbal_axes"
    with pytest.raises(InputError) as e:
        envelope_points(alpha, 0)
    assert e.value.field == "envelope.n_points"
    with pytest.raises(InputError) as e:
        singular_momenta(g[0], EXTERNAL, g)
    assert e.value.field == "envelope.u"


def test_rrd_file_holds_the_envelope_and_surfaces(tmp_path):
    import rerun.chunk

    path = write_envelope_rrd(tmp_path / "envelope.rrd", np.radians(45.0), 1.5, 800)
    assert path.exists() and path.stat().st_size > 0
    found = {}
    for chunk in rerun.chunk.RrdReader(path).stream():
        batch = chunk.to_record_batch()
        if "Points3D:positions" in batch.schema.names:
            positions = batch.column("Points3D:positions")[0].as_py()
            found[str(chunk.entity_path)] = np.array(positions)
    assert "/envelope/external" in found
    assert len([k for k in found if k.startswith("/envelope/internal/")]) == 7
    expected = envelope_points(np.radians(45.0), 800, 1.5)
    np.testing.assert_allclose(found["/envelope/external"], expected, rtol=1e-6, atol=1e-6)


# --- what the cluster can hold: the gauge of momentum_gauge.py --------------------------------

def _pair_reachable(P, alpha, h):
    """A second method for the rhombus: CMGs 1, 3 share gimbal axis g1 and 2, 4 share g2, so the
    cluster holds P iff P = a + b with a in the disk of radius 2h normal to g1 and b in that normal
    to g2. Both planes contain z; with P = p e1 + q e2 + c z (e1, e2 the planes' horizontal
    directions) that is |p|, |q| <= 2h and |c| <= sqrt(4h^2 - p^2) + sqrt(4h^2 - q^2)."""
    e1 = np.array([np.cos(alpha), np.sin(alpha)])
    e2 = np.array([-np.cos(alpha), np.sin(alpha)])
    p, q = np.linalg.solve(np.column_stack([e1, e2]), P[:2])
    if abs(p) > 2 * h or abs(q) > 2 * h:
        return False
    return abs(P[2]) <= np.sqrt(4 * h * h - p * p) + np.sqrt(4 * h * h - q * q)


def _pair_gauge(P, alpha, h):
    """The s with P / s on the boundary of what the pairs hold (bisection on _pair_reachable)."""
    low, high = 0.0, 100.0
    for _ in range(80):
        mid = 0.5 * (low + high)
        low, high = (low, mid) if _pair_reachable(P / mid, alpha, h) else (mid, high)
    return high


def test_gauge_reaches_the_envelope_extents_and_the_inscribed_circle():
    """4h along z, 4h cos a along x, 4h sin a along y (`testbed envelope` prints the same); at
    height 0 the section is the rhombus |p|, |q| <= 2h, whose inscribed circle has radius
    2h sin 2a, touching the edge p = 2h along its normal (1/cos a, 1/sin a)."""
    alpha, h = np.radians(54.7356), 75.0
    g = rhombus_gimbal_axes(alpha)
    normal = np.array([1 / np.cos(alpha), 1 / np.sin(alpha), 0.0])
    normal /= np.linalg.norm(normal)
    P = np.array([[0, 0, 4 * h], [0, 0, -4 * h], [4 * h * np.cos(alpha), 0, 0], [0, 4 * h * np.sin(alpha), 0],
                  2 * h * np.sin(2 * alpha) * normal, 0.5 * 2 * h * np.sin(2 * alpha) * normal])
    gauge, u = envelope_gauge(P, g, h)
    assert gauge == pytest.approx([1, 1, 1, 1, 1, 0.5], abs=1e-9)
    assert u[0] == pytest.approx([0, 0, 1], abs=1e-6)


@pytest.mark.parametrize("alpha", ALPHAS)
def test_gauge_is_the_pair_decomposition_and_bounds_every_gimbal_state(alpha):
    """The gauge agrees with the pair decomposition (a second method, exact for this layout) on
    random momenta, every momentum of random gimbal angles (eq. 15) has gauge <= 1, and every
    torque h J beta' with |beta'_i| <= beta'max has gauge <= beta'max (module doc of momentum_gauge)."""
    h, rate = 20.0, 0.3
    g = rhombus_gimbal_axes(alpha)
    rng = np.random.default_rng(int(100 * alpha))
    P = rng.normal(size=(60, 3)) * 2 * h
    gauge, u = envelope_gauge(P, g, h)
    exact = np.array([_pair_gauge(p, alpha, h) for p in P])
    # a lower bound (each u gives one) that the search brings to within 1e-5 (measured 3.4e-6
    # at worst, a maximum in a narrow wedge next to a kink ±g_i; 1e-9 elsewhere)
    assert np.all(gauge <= exact * (1 + 1e-9)) and np.all(gauge >= exact * (1 - 1e-5))
    assert np.median(np.abs(gauge / exact - 1)) < 1e-9
    beyond = gauge > 1    # the certificate: the plane u.H = S(u) separates P from every state
    assert np.all(np.einsum("ij,ij->i", u[beyond], P[beyond]) > envelope_support(u[beyond], g, h))
    beta = rng.uniform(-np.pi, np.pi, (400, 4))
    assert envelope_gauge(_H_eq15(beta, alpha, h), g, h)[0].max() <= 1 + 1e-9
    e, s, _ = rhombus_geometry(alpha)
    torque = np.einsum("kij,kj->ki", h * np.stack([-np.sin(beta[..., None]) * e + np.cos(beta[..., None]) * s[:, None]
                                                   * np.array([0, 0, 1.0])], 1)[:, 0].transpose(0, 2, 1),
                       rate * rng.choice([-1.0, 1.0], (400, 4)))
    assert envelope_gauge(torque, g, h)[0].max() <= rate * (1 + 1e-9)
