"""Observer gain for a time-varying pair (A(t), c') with a prescribed rate of decay: the
Kalman-Bucy filter without process noise, in information form.

For an estimation error obeying e' = (A(t) - l(t) c') e (one scalar measurement c' x), let the
information matrix Pi obey the linear matrix equation

    Pi' = -(A + a 1)' Pi - Pi (A + a 1) + c c',        l = Pi^-1 c.

Then V = e' Pi e obeys (substitute and the cross terms cancel)

    V' = e' (Pi' + Pi A + A' Pi - 2 c c') e = -2 a V - (c' e)^2 <= -2 a V,

so the error decays at least as e^(-a t) in the norm Pi defines, whatever A(t) does, for as long
as Pi stays positive definite and bounded. Pi(t) is the observability Gramian of the pair
weighted by e^(-2 a (t - s)) (information older than 1/2a is forgotten): it stays positive
definite iff the pair is observable over such windows, which is weaker than observable at every
instant (det [c; c A; c A^2] may pass through 0). For a constant A whose eigenvalues lie on the
imaginary axis the steady Pi places eig(A - l c') at those eigenvalues shifted by -2a (the
mirror image of eig(A + a 1) about the imaginary axis, shifted by -a): a = r / 2 gives the rate r.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm


def information_rate(A, info, decay: float, c) -> np.ndarray:
    """Pi' = -(A + a 1)' Pi - Pi (A + a 1) + c c' (module doc), A (n, n), Pi (n, n), a = `decay`."""
    shifted = np.asarray(A, float) + decay * np.eye(len(c))
    product = shifted.T @ info
    return np.outer(c, c) - product - product.T     # Pi is symmetric: Pi S = (S' Pi)'


def filter_gain(info, c) -> np.ndarray:
    """l = Pi^-1 c (module doc)."""
    return np.linalg.solve(info, np.asarray(c, float))


def gathered_information(A, decay: float, c, horizon: float) -> np.ndarray:
    """Pi after `horizon` [s] from Pi = 0 with A held constant:
    int_0^T e^(-S' s) c c' e^(-S s) ds, S = A + a 1 (Van Loan's block exponential)."""
    n = len(c)
    shifted = np.asarray(A, float) + decay * np.eye(n)
    block = np.zeros((2 * n, 2 * n))
    block[:n, :n], block[:n, n:], block[n:, n:] = shifted.T, np.outer(c, c), -shifted
    with np.errstate(under="ignore"):   # decaying modes underflow harmlessly
        exp = expm(block * horizon)     # [[F11, F12], [0, F22]]: the integral is F22' F12
    info = exp[n:, n:].T @ exp[:n, n:]
    return (info + info.T) / 2
