"""Rank-revealing least squares for the unit-h Jacobian: the fallback at singularities.

At a singular gimbal set (rank J < 3, e.g. beta = 0 has rank 1; beta1 = beta3 and
beta2 = beta4 has rank 2) the demand b = H'/h is generally unreachable. Every law then
delivers the least-squares projection of b onto range(J): the closest achievable momentum
rate in the Euclidean norm. The rank is decided by the SVD with a relative tolerance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

DEFAULT_RCOND = 1e-9  # singular values <= rcond * sigma_max count as zero


@dataclass(slots=True)
class JacobianSVD:
    """Thin SVD of J (3x4) cut to its numerical rank.

    u: (3, r), s: (r,), vt: (r, 4) with J ~= u diag(s) vt; null_space: (4 - r, 4) rows
    spanning ker J; measure: sqrt(det(J J^T)) = product of all three singular values.
    """

    u: np.ndarray
    s: np.ndarray
    vt: np.ndarray
    null_space: np.ndarray
    rank: int
    measure: float


def jacobian_svd(J: np.ndarray, rcond: float = DEFAULT_RCOND) -> JacobianSVD:
    """SVD of J with rank = number of singular values > rcond * sigma_max."""
    u, s, vt = np.linalg.svd(J, full_matrices=True)
    rank = numerical_rank(s, rcond)
    return JacobianSVD(u[:, :rank], s[:rank], vt[:rank], vt[rank:], rank, float(np.prod(s)))


def numerical_rank(s: np.ndarray, rcond: float):
    """How many singular values s (k,), descending, exceed rcond * s_max (0 when s_max = 0): an int;
    of many worlds' s (N, k), an array (N,)."""
    if s.ndim == 1:  # one world: numpy's reductions along an axis cost more than these two calls
        return int(np.count_nonzero(s > rcond * s[0])) if s[0] > 0 else 0
    first = s[..., :1]
    return np.count_nonzero((s > rcond * first) & (first > 0), axis=-1)


def min_norm_rows(u: np.ndarray, s: np.ndarray, vt: np.ndarray, b: np.ndarray, rcond: float) -> tuple:
    """`min_norm_solution` of N worlds from their full SVDs, a row each: u (N, 3, 3), s (N, 3),
    vt (N, n, n), b (N, 3) -> (x (N, n), rank (N,)); singular values at or below rcond s_max dropped."""
    rank = numerical_rank(s, rcond)
    kept = np.arange(s.shape[-1]) < rank[:, None]
    scaled = np.divide((b[:, None, :] @ u)[:, 0, :], s, out=np.zeros_like(s), where=kept)
    return (scaled[:, None, :] @ vt[:, : s.shape[-1], :])[:, 0, :], rank


def min_norm_solution(svd: JacobianSVD, b: np.ndarray) -> np.ndarray:
    """Minimum-norm least-squares solution of J x = b: x = V_r S_r^-1 U_r^T b (pinv, eq. 20)."""
    return svd.vt.T @ ((svd.u.T @ b) / svd.s)


def project_onto_range(svd: JacobianSVD, b: np.ndarray) -> np.ndarray:
    """Orthogonal projection of b onto range(J) = U_r U_r^T b (the reachable part of b)."""
    return svd.u @ (svd.u.T @ b)
