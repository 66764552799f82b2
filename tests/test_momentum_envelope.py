"""Momentum envelope and singular surfaces of the 4-CMG rhombus (SEEDS §004 eq. 15, 18),
checked against eq. (15) written out term by term and its analytic Jacobian."""

import numpy as np
import pytest

from testbed.errors import InputError
from testbed.systems.cmg_rhombus.momentum_envelope import (
    EXTERNAL,
    envelope_points,
    fibonacci_sphere,
    rhombus_geometry,
    rhombus_gimbal_axes,
    singular_momenta,
    singular_surface_points,
    write_envelope_rrd,
)

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
