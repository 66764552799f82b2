"""Which kind of singular state a gimbal set is near: Bedrossian's test (Bedrossian, Paradiso &
Bergmann 1990, J. Guid. Control Dyn. 13(6), "Steering law design for redundant single-gimbal
control moment gyroscopes"; Kurokawa 2007, J. Guid. Control Dyn. 30(5), section II).

At a singular state every torque axis c_i (column i of J) is normal to the singular direction u,
the left null vector of J. To second order a gimbal motion d beta in the null space, d beta = N a,
moves the momentum along u by (1/2) a^T Q a with

    Q = N^T P N,   P = diag(u . h_i''),   h_i'' = d^2 h_i / d beta_i^2 = dJ_i/dbeta_i.

Q definite: elliptic, no null motion leaves the state (the momentum along u can only move one way);
Q indefinite: hyperbolic, null motion can leave it; Q singular: degenerate (null motion may move
along the singular set). Near (not at) a singular state the test is taken with u the left singular
vector of the smallest singular value and N the right singular vectors of the two smallest
(the null space of the nearest rank-2 Jacobian). Definiteness does not depend on the sign of u;
u is returned with u . H >= 0 when H is given.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

NOT_SINGULAR, HYPERBOLIC, ELLIPTIC, DEGENERATE = 0, 1, 2, 3  # codes recorded in the trace
KIND_NAMES = {NOT_SINGULAR: "not singular", HYPERBOLIC: "hyperbolic", ELLIPTIC: "elliptic", DEGENERATE: "degenerate"}
DEGENERATE_TOLERANCE = 1e-3  # |eigenvalue of Q| below this share of max|P| counts as zero


@dataclass(slots=True)
class SingularityType:
    """direction u (3,), kind (HYPERBOLIC, ELLIPTIC or DEGENERATE), eigenvalues of Q (ascending)."""

    direction: np.ndarray
    kind: int
    eigenvalues: np.ndarray


def singularity_type(J, column_derivative, momentum=None, tolerance: float = DEGENERATE_TOLERANCE) -> SingularityType:
    """Bedrossian's test (module doc) at the gimbal set where J (3, n) and dJ_i/dbeta_i (3, n) were taken."""
    J = np.asarray(J, dtype=float)
    u_all, _, vt = np.linalg.svd(J, full_matrices=True)
    u = u_all[:, 2]
    if momentum is not None and float(u @ np.asarray(momentum, float)) < 0:
        u = -u
    N = vt[2:].T  # (n, n - 2)
    p = u @ np.asarray(column_derivative, dtype=float)  # u . h_i''
    eigenvalues = np.linalg.eigvalsh(N.T @ (p[:, None] * N))
    floor = tolerance * max(float(np.max(np.abs(p))), 1e-300)
    if np.min(np.abs(eigenvalues)) <= floor:
        kind = DEGENERATE
    elif eigenvalues[0] * eigenvalues[-1] > 0:
        kind = ELLIPTIC
    else:
        kind = HYPERBOLIC
    return SingularityType(u, kind, eigenvalues)
