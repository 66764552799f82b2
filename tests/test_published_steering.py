"""The published steering laws (osr, sda, pga) and Bedrossian's singularity test, each against a
number derived by hand or computed independently in the test (docs/theory/steering.md "Published laws")."""

from __future__ import annotations

import numpy as np
import pytest
from rerun.chunk import RrdReader

import testbed
from testbed.steering import steer
from testbed.steering.singularity_type import DEGENERATE, ELLIPTIC, HYPERBOLIC, singularity_type
from testbed.systems.cmg_cluster.arrays import rhombus_axes
from testbed.systems.cmg_cluster.cluster import ClusterGeometry
from testbed.systems.cmg_cluster.momentum_envelope import singular_momenta

ALPHA = np.radians(54.7356)
RATE_MAX = np.radians(30.0)


def geometry() -> ClusterGeometry:
    e, g, _ = rhombus_axes(ALPHA)
    return ClusterGeometry(g, e, np.ones(4), 1.0)  # h = 1


def fly(law: str, geo, beta, b, seconds: float, dt: float = 0.01, **options):
    """Euler-integrate beta' = law(J(beta), b) from beta; returns the angles at each step."""
    path = [np.array(beta, float)]
    for k in range(int(round(seconds / dt))):
        t = k * dt
        extra = {"t": t} if law in ("osr", "gsr") else {}
        if law == "pga":
            extra = {"gimbal_angle": path[-1], "preferred_gimbal_angles": path[0]}
        rate = steer(law, geo.unit_jacobian(path[-1]), 1.0, b, RATE_MAX, **extra, **options).beta_rate
        path.append(path[-1] + dt * rate)
    return np.array(path)


def test_osr_leaves_the_singular_start_that_pinv_cannot():
    # beta = 0: every column of J is s_i z (rank 1), sqrt(det(J J^T)) = 0, H = 0. A demand along x
    # is normal to range(J): pinv's rates are exactly zero and it never leaves. By hand, with W of
    # Wie 2005: J W J^T = (s^T W s) z z^T = 4 (1 - lambda0) z z^T and W s = (1 - lambda0) s, so
    # beta' = (1 - lambda0) y_z s with y = (4 (1 - lambda0) z z^T + lambda0 E(0))^-1 b.
    geo = geometry()
    b = np.array([0.05, 0.0, 0.0])
    assert np.all(steer("pinv", geo.unit_jacobian(np.zeros(4)), 1.0, b, RATE_MAX).beta_rate == 0.0)
    lam, eps = 0.01, 0.1 * np.sin(np.array([0.0, np.pi / 2, np.pi]))
    E = np.array([[1, eps[2], eps[1]], [eps[2], 1, eps[0]], [eps[1], eps[0], 1]])
    z = np.array([0.0, 0.0, 1.0])
    y = np.linalg.solve(4 * (1 - lam) * np.outer(z, z) + lam * E, b)
    by_hand = (1 - lam) * y[2] * np.array([1.0, 1.0, -1.0, -1.0])
    got = steer("osr", geo.unit_jacobian(np.zeros(4)), 1.0, b, RATE_MAX, t=0.0).beta_rate
    np.testing.assert_allclose(got, by_hand, rtol=1e-9)  # a well-conditioned 3x3 solve
    # Flown for 20 s, osr leaves the singular set (sqrt det >= 0.05) and then delivers the demand;
    # pinv stays at beta = 0.
    osr = fly("osr", geo, np.zeros(4), b, 20.0)
    measure = geo.singularity_measure(osr)
    assert measure[-1] >= 0.05 and measure.max() >= 0.3
    delivered = geo.unit_jacobian(osr[-1]) @ steer("osr", geo.unit_jacobian(osr[-1]), 1.0, b, RATE_MAX, t=20.0).beta_rate
    assert np.linalg.norm(delivered - b) <= 1e-2 * np.linalg.norm(b)
    assert np.all(fly("pinv", geo, np.zeros(4), b, 1.0) == 0.0)


def test_sda_errs_only_along_the_singular_direction_by_the_papers_gain():
    # Near a singular set, Ford and Hall's inverse delivers the demand exactly in the two
    # well-conditioned directions and with the gain s3^2 / (s3^2 + lambda0 exp(-mu s3^2)) along u3
    # (computed here from numpy's SVD of J); pinv's rates grow like 1/s3, SDA's stay bounded.
    geo = geometry()
    for beta in (np.radians([10.0, -20.0, 10.3, -20.0]), np.radians([30.0, 60.0, 30.05, 60.0])):
        J = geo.unit_jacobian(beta)
        u, s, _ = np.linalg.svd(J)
        assert s[2] < 0.02  # near the singular family beta1 = beta3, beta2 = beta4
        b = 0.01 * (u[:, 0] + u[:, 2])
        delivered = J @ steer("sda", J, 1.0, b, np.inf).beta_rate
        gain = s[2] ** 2 / (s[2] ** 2 + 0.01 * np.exp(-10 * s[2] ** 2))
        np.testing.assert_allclose(u.T @ delivered, [0.01, 0.0, 0.01 * gain], atol=1e-12)
        assert np.abs(steer("sda", J, 1.0, b, np.inf).beta_rate).max() < 0.2 * np.abs(
            steer("pinv", J, 1.0, b, np.inf).beta_rate).max()


def test_pga_null_motion_returns_to_the_preferred_angles_at_constant_momentum():
    # With no demand the pga rates are k (I - J^+ J)(beta^p - beta): pure null motion. Started a
    # small step along the null vector v of J(beta^p), the distance decays like exp(-k t) (linear
    # in the small error), and H stays at H(beta^p) (no torque: conservation). Euler with dt k = 0.005.
    geo = geometry()
    preferred = np.radians([45.0, -45.0, -45.0, 45.0])
    v = np.linalg.svd(geo.unit_jacobian(preferred))[2][3]
    start = preferred + 0.02 * v
    path = [start]
    for _ in range(400):
        rate = steer("pga", geo.unit_jacobian(path[-1]), 1.0, np.zeros(3), RATE_MAX, gimbal_angle=path[-1],
                     preferred_gimbal_angles=preferred, null_gain_per_s=0.5).beta_rate
        path.append(path[-1] + 0.01 * rate)
    distance = np.linalg.norm(np.array(path) - preferred, axis=1)
    expected = 0.02 * np.exp(-0.5 * 0.01 * np.arange(401))
    np.testing.assert_allclose(distance, expected, rtol=2e-2)  # Euler and second-order terms
    assert np.abs(geo.momentum(np.array(path)) - geo.momentum(preferred)).max() < 1e-3


def _singular_set(geo, u, signs):
    """Gimbal angles of the singular state H(u, signs) (momentum_envelope.singular_momenta)."""
    hs = singular_momenta(u[None], signs, geo.gimbal_axes)[0]
    return np.arctan2(np.einsum("ij,ij->i", hs, geo.turn_axes), np.einsum("ij,ij->i", hs, geo.spin_axes_zero))


@pytest.mark.parametrize("signs, kind, sign_b", [((1, 1, 1, 1), ELLIPTIC, 1), ((1, -1, 1, -1), HYPERBOLIC, -1),
                                                 ((1, 1, 1, -1), DEGENERATE, 0), ((1, 1, -1, -1), DEGENERATE, None)])
def test_bedrossian_test_on_the_rhombus_singular_states(signs, kind, sign_b):
    # By hand: the rhombus's units 1, 3 share a gimbal axis, and so do 2, 4. At the singular state
    # h_i = eps_i (g_i x u) x g_i / |g_i x u|, u . h_i = eps_i a_i with a_i = |g_i x u|, so
    # P = diag(u . h_i'') = -diag(eps_i a_i); c_3 = eps_1 eps_3 c_1 and c_4 = eps_2 eps_4 c_2, so the null
    # space is spanned by (1, 0, -eps1 eps3, 0)/sqrt2 and (0, 1, 0, -eps2 eps4)/sqrt2 and Q is
    # diag(-(eps1 + eps3) a_1 / 2, -(eps2 + eps4) a_2 / 2): eigenvalues {-a_1, -a_2} for ++++ (elliptic),
    # {-a_1, +a_2} for +-+- (hyperbolic), {-a_1, 0} for +++- and {0, 0} for ++-- (degenerate).
    geo = geometry()
    u = np.array([0.3, 0.5, 0.8]) / np.linalg.norm([0.3, 0.5, 0.8])
    beta = _singular_set(geo, u, signs)
    found = singularity_type(geo.unit_jacobian(beta), geo.unit_jacobian_derivative(beta), geo.momentum(beta))
    assert found.kind == kind
    assert abs(abs(found.direction @ u) - 1.0) < 1e-9
    a = np.linalg.norm(np.cross(geo.gimbal_axes, u), axis=1)
    expected = {1: [-a[0], -a[1]], -1: [-a[0], a[1]], 0: [-a[0], 0.0], None: [0.0, 0.0]}[sign_b]
    np.testing.assert_allclose(found.eigenvalues, np.sort(expected), atol=1e-9)


def test_the_stage_records_the_singularity_type_near_a_singular_set(tmp_path):
    # reorient_near_singular with min-max comes within 1e-3 of a singular set (docs/theory/steering.md):
    # below classify_below the trace holds the kind and a unit u normal to every column of J.
    out = tmp_path / "near.rrd"
    result = testbed.run("reorient_near_singular", out=out, overrides=["sim.duration_s=40",
                                                                         "pipeline.allocator.classify_below=0.2"])
    _, kind = result.trace["allocator/singularity_type"]
    _, direction = result.trace["allocator/singular_direction"]
    _, measure = result.trace["allocator/singularity"]
    near = measure[:, 0] < 0.2
    assert near.any() and np.all(kind[near, 0] > 0) and np.all(kind[~near, 0] == 0)
    np.testing.assert_allclose(np.linalg.norm(direction[near], axis=1), 1.0, atol=1e-9)
    _, beta = result.trace["truth/gimbal_angle"]
    geo = geometry()
    columns = geo.unit_jacobian(beta[:len(near)][near])  # the angles each command was computed at
    # u is the left singular vector of the smallest singular value: |u^T J| = s3 <= sqrt det / s1 s2
    assert np.abs(np.einsum("ki,kij->kj", direction[near], columns)).max() < 0.2
    # the momentum view marks the path's H at exactly the samples of each kind (read back from the .rrd)
    _, momentum = result.trace["truth/cmg_momentum"]
    marked = {}
    for chunk in RrdReader(str(out)).stream():
        entity = str(chunk.entity_path)
        if entity.startswith("/momentum_space/singular/"):
            batch = chunk.to_record_batch()
            if "Points3D:positions" in batch.schema.names:
                name = entity.split("/")[3]
                marked.setdefault(name, []).extend(batch.column("Points3D:positions").to_pylist()[0])
    names = {HYPERBOLIC: "hyperbolic", ELLIPTIC: "elliptic", DEGENERATE: "degenerate"}
    assert set(marked) == {names[int(k)] for k in np.unique(kind[near, 0])} and {"hyperbolic", "elliptic"} <= set(marked)
    for code, name in names.items():
        rows = momentum[:len(kind)][kind[:, 0] == code]
        np.testing.assert_allclose(np.array(marked.get(name, np.zeros((0, 3)))).reshape(-1, 3), rows, rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("law", ["osr", "sda", "pga"])
def test_each_law_runs_as_a_stage_and_refuses_a_bad_option(law, tmp_path):
    from testbed.cli.dispatch import main
    bad = {"osr": "epsilon0=0.7", "sda": "mu=-1", "pga": "null_gain_per_s=-1"}[law]
    common = ["run", "reorient_near_singular", "--out", str(tmp_path / "run.rrd"),
              "--set", f"pipeline.allocator.type={law}"]
    assert main([*common, "--set", f"pipeline.allocator.options.{bad}"]) == 2
    assert not (tmp_path / "run.rrd").exists()
    flown = testbed.run("reorient_near_singular", overrides=[f"pipeline.allocator.type={law}", "sim.duration_s=8"])
    # 3 s into the slew: the law's command delivers the wanted torque (all three are exact far from
    # a singular set) within the rate limit
    assert flown.status == "ok" and flown.metrics["rate_limit_violations"] == 0
    assert flown.metrics["max_tracking_error_deg"] < 0.05
