"""Exact min-max rates for a cluster of n > 4 units from the LP's dual, without an LP solver.

min s subject to J x = b, |x_i| <= s (SEEDS §004 eq. (21)) has the dual max b.y subject to
sum_k |J_k . y| <= 1: s* is the gauge of b in the zonotope Z = {J x : |x|_inf <= 1}, and the
optimal y is a vertex of the polar of Z, i.e. the unit normal u of a facet of Z. A 3-D zonotope's
facets are spanned by pairs of its generators, so u is one of the n(n-1)/2 normals J_i x J_j, the
one with the largest |b.u| / sum_k |J_k.u| (that ratio is s*). Complementary slackness then fixes
every rate whose column is off the facet's plane at the bound, x_k = s* sign(J_k.u), and the
rates of the columns in it (J_i, J_j, and any parallel to them) solve J x = b for the rest, the
minimum-norm solution of that small system.

The answer is certified before it is returned: J x = b to rounding and every free rate within s*.
A degenerate facet (three or more columns in its plane, where the minimum-norm choice of the free
rates may pass s* although another choice does not) fails the certificate, and the caller falls
back to the LP (minimax_lp.nullspace_lp_rates). The closed form costs tens of microseconds where
HiGHS costs milliseconds; tests/test_cmg_cluster.py holds the two to 1e-9.
"""

from __future__ import annotations

import numpy as np

# columns whose dot product with the facet normal is below this share of the largest lie in its plane
IN_PLANE = 1e-9
# the certificate's slack: rounding of a few products of O(1) numbers
CERTIFICATE = 1e-10


def dual_minimax_rates(J: np.ndarray, b: np.ndarray) -> np.ndarray | None:
    """argmin max|x_i| subject to J x = b (J: 3 x n of rank 3, b: (3,)), from the dual (module
    doc); None when the certificate fails (a degenerate facet): then solve the LP."""
    units = J.shape[1]
    scale = float(np.abs(J).max())
    if not np.any(b):
        return np.zeros(units)
    first, second = np.triu_indices(units, 1)
    normals = np.cross(J[:, first].T, J[:, second].T)
    lengths = np.linalg.norm(normals, axis=1)
    spanning = lengths > 1e-12 * scale * scale  # a parallel pair spans no facet
    normals = normals[spanning] / lengths[spanning, None]
    ratios = np.abs(normals @ b) / np.abs(normals @ J).sum(axis=1)
    best = int(np.argmax(ratios))
    peak = float(ratios[best])
    u = normals[best] * np.sign(normals[best] @ b)
    along = J.T @ u
    bound = np.abs(along) > IN_PLANE * np.abs(along).max()
    rates = np.where(bound, peak * np.sign(along), 0.0)
    free = ~bound
    rest = b - J[:, bound] @ rates[bound]
    rates[free] = np.linalg.lstsq(J[:, free], rest, rcond=None)[0]
    size = float(np.linalg.norm(b)) + peak * scale
    if (np.abs(rates[free]).max() > peak * (1.0 + CERTIFICATE)
            or np.abs(J @ rates - b).max() > CERTIFICATE * size):
        return None
    return rates
