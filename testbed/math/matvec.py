"""Matrix times vector on stacks of them: one matrix and vector per row of a batch."""

import numpy as np


def matvec(m, v) -> np.ndarray:
    """m v for (..., r, c) matrices and (..., c) vectors broadcast over their leading axes.
    Products and a sum along the rows, in the same order whatever the leading axes: a world's
    row of a batch is its single run's to the bit (matmul's kernels differ between one matrix
    and a stack of them)."""
    return np.sum(m * v[..., None, :], axis=-1)
