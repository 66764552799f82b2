"""Checks that a scenario's physical parameters describe something that can exist."""

import numpy as np

from testbed.errors import InputError


def check_principal_inertia(inertia, path: str) -> None:
    """Principal inertias must be positive and obey the triangle inequality I_i <= I_j + I_k."""
    values = np.asarray(inertia, float)
    if np.any(values <= 0):
        raise InputError(path, f"principal inertias must be > 0, got {list(values)}")
    total = values.sum()
    for i, value in enumerate(values):
        if value > total - value + 1e-12 * total:
            raise InputError(path, f"violates the triangle inequality: I[{i}] = {value:g} > sum of the other two")


def check_unit_vector(vector, path: str) -> np.ndarray:
    """A unit 3-vector; a zero or non-unit vector is refused (never silently normalised)."""
    v = np.asarray(vector, float)
    norm = float(np.linalg.norm(v))
    if norm == 0.0:
        raise InputError(path, "must not be the zero vector")
    if abs(norm - 1.0) > 1e-9:
        raise InputError(path, f"must be a unit vector, |v| = {norm:.9g}")
    return v


def finite_number(field: str, value) -> float:
    """`value` as a finite float, else InputError naming `field`."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(field, f"must be a number, got {value!r}") from None
    if not np.isfinite(x):
        raise InputError(field, f"must be finite, got {value!r}")
    return x


def positive_number(field: str, value) -> float:
    """`value` as a finite float > 0, else InputError naming `field`."""
    x = finite_number(field, value)
    if x <= 0:
        raise InputError(field, f"must be > 0, got {x:g}")
    return x
