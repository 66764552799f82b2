"""Checks of user-supplied numbers, vectors and inertias: each returns the checked value or
raises InputError naming the field and the reason (never silently repairs bad input)."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from testbed.errors import InputError, quoted
from testbed.scenario.schema import UNIT_RANGES


def finite_number(field: str, value) -> float:
    """`value` as a finite float."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(field, f"must be a number, got {quoted(value)}") from None
    if not math.isfinite(x):
        raise InputError(field, f"must be finite, got {quoted(value)}")
    return x


def positive_number(field: str, value, allow_inf: bool = False) -> float:
    """`value` as a float > 0, finite unless `allow_inf` (plain floats: cheap enough for hot paths)."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(field, f"must be a number > 0, got {quoted(value)}") from None
    if not x > 0:  # also refuses nan
        raise InputError(field, f"must be > 0, got {x:g}")
    if not allow_inf and math.isinf(x):
        raise InputError(field, "must be finite")
    return x


def number_in(field: str, value, low: float, high: float, low_open=False, high_open=False) -> float:
    """`value` as a float in the interval [low, high] (either end open if asked)."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(field, "must be a number") from None
    below = x <= low if low_open else x < low
    above = x >= high if high_open else x > high
    if math.isnan(x) or below or above:
        lb, hb = "(" if low_open else "[", ")" if high_open else "]"
        raise InputError(field, f"must be in {lb}{low}, {high}{hb}")
    return x


def positive_count(field: str, value) -> int:
    """`value` as an int >= 1 (a bool is not a count)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise InputError(field, f"must be a positive integer, got {quoted(value)}")
    return int(value)


def vector3(field: str, value) -> np.ndarray:
    """`value` as a float (3,) array of finite numbers."""
    try:
        v = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(field, f"must be 3 finite numbers, got {quoted(value)}") from None
    if v.size != 3 or not np.all(np.isfinite(v)):
        raise InputError(field, f"must be 3 finite numbers, got {v.tolist()}")
    return v


# The one rule for every unit vector and quaternion a user gives (axes, attitudes): its length
# must be within UNIT_TOLERANCE of 1 (four figures, as typed by hand: [0.577, 0.577, 0.577]
# passes) and it is divided by its length; zero, or farther from 1, is refused.
UNIT_TOLERANCE = 1e-3


def _to_unit(field: str, v: np.ndarray, what: str, tol: float) -> np.ndarray:
    norm = float(np.linalg.norm(v))
    if norm == 0.0:
        raise InputError(field, f"must be a unit {what}, got the zero {what}")
    if abs(norm - 1.0) > tol:
        raise InputError(field, f"must be a unit {what} (length within {tol:g} of 1), its length is {norm:.9g}")
    return v / norm


def check_unit_vector(vector, path: str, tol: float = UNIT_TOLERANCE) -> np.ndarray:
    """A 3-vector of length 1 +- tol, returned divided by its length (UNIT_TOLERANCE rule)."""
    return _to_unit(path, vector3(path, vector), "vector", tol)


def unit_quaternion(field: str, q, tol: float = UNIT_TOLERANCE) -> np.ndarray:
    """A quaternion (w, x, y, z) of length 1 +- tol, returned divided by its length."""
    q = np.asarray(q, dtype=float)
    if q.shape != (4,) or not np.all(np.isfinite(q)):
        raise InputError(field, f"must be 4 finite numbers (w, x, y, z), got {quoted(q.tolist())}")
    return _to_unit(field, q, "quaternion", tol)


def principal_moments(field: str, inertia) -> np.ndarray:
    """Three positive principal moments of inertia as a float (3,) array."""
    values = np.asarray(inertia, dtype=float)
    if values.shape != (3,) or not np.all(np.isfinite(values)) or np.any(values <= 0):
        raise InputError(field, f"must be three positive principal moments, got {values.tolist()}")
    return values


INERTIA_RANGE_KG_M2 = UNIT_RANGES["_kg_m2"]
MASS_RANGE_KG = UNIT_RANGES["_kg"]


def check_in_range(field: str, value: float, bounds: tuple[float, float], unit: str) -> float:
    low, high = bounds
    if not low <= value <= high:
        raise InputError(field, f"must lie in [{low:g}, {high:g}] {unit}, got {value:g}")
    return value


def check_principal_inertia(inertia, path: str) -> None:
    """Principal inertias must lie in INERTIA_RANGE_KG_M2 and obey the triangle inequality
    I_i <= I_j + I_k."""
    values = np.asarray(inertia, float)
    if np.any(values <= 0):
        raise InputError(path, f"principal inertias must be > 0, got {values.tolist()}")
    for value in values:
        check_in_range(path, float(value), INERTIA_RANGE_KG_M2, "kg m^2")
    total = values.sum()
    for i, value in enumerate(values):
        if value > total - value + 1e-12 * total:
            raise InputError(path, f"violates the triangle inequality: I[{i}] = {value:g} > sum of the other two")


def check_positive_definite(matrix, path: str, symmetric: bool) -> np.ndarray:
    """A 3x3 matrix M with x^T M x > 0 for x != 0; `symmetric` also asks M = M^T."""
    m = np.asarray(matrix, float)
    if m.shape != (3, 3) or not np.all(np.isfinite(m)):
        raise InputError(path, "must be a 3x3 matrix of finite numbers")
    if np.abs(m).max() > 1e12:  # beyond any gain or inertia here, and where eigvalsh overflows
        raise InputError(path, f"entries must lie within +-1e12, got {np.abs(m).max():g}")
    if symmetric and not np.allclose(m, m.T, rtol=0, atol=1e-12 * np.abs(m).max()):
        raise InputError(path, "must be a symmetric matrix")
    smallest = float(np.linalg.eigvalsh((m + m.T) / 2)[0])
    if smallest <= 0:
        raise InputError(path, f"must be positive definite, its (symmetric part's) smallest eigenvalue is {smallest:g}")
    return m


def inertia_matrix(field: str, inertia) -> np.ndarray:
    """An inertia as a symmetric positive-definite (3, 3) matrix [kg m^2], from three principal
    moments or a full tensor."""
    a = np.asarray(inertia, dtype=float)
    if a.shape == (3,):
        a = np.diag(a)
    if a.shape != (3, 3) or not np.all(np.isfinite(a)):
        raise InputError(field, "must be 3 principal moments or a 3x3 matrix of finite numbers")
    if np.abs(a - a.T).max() > 1e-12 * np.abs(a).max():
        raise InputError(field, "must be symmetric")
    return check_positive_definite(a, field, symmetric=True)


def existing_file(field: str, path) -> bool:
    """Whether `path` names an existing regular file; a name the file system cannot take (too
    long, a NUL byte), an empty one or one that is not a path at all is refused rather than raising."""
    if not isinstance(path, (str, os.PathLike)):
        raise InputError(field, f"must be a file path (str or pathlib.Path), got {type(path).__name__}")
    if not str(path):  # Path("") is the current folder
        raise InputError(field, "is empty; give a file name")
    try:
        return Path(path).is_file()
    except (OSError, ValueError) as exc:
        raise InputError(field, f"{quoted(str(path))} is not a usable file name: {getattr(exc, 'strerror', None) or exc}") from None


def check_inertia_tensor(tensor, path: str) -> np.ndarray:
    """A full inertia tensor [kg m^2] (3x3, products of inertia off the diagonal, the tensor's own
    entries I_xy = -sum m x y) as a float (3, 3) array, refused unless symmetric, positive definite,
    with principal moments in INERTIA_RANGE_KG_M2 and obeying the triangle inequality
    I_i <= I_j + I_k (any rigid body's principal moments do)."""
    m = np.asarray(tensor, dtype=float)
    if m.shape != (3, 3) or not np.all(np.isfinite(m)):
        raise InputError(path, f"must be a 3x3 matrix of finite numbers, got {quoted(tensor)}")
    asymmetry = np.abs(m - m.T)
    if asymmetry.max() > 1e-12 * np.abs(m).max():
        i, j = np.unravel_index(int(np.argmax(asymmetry)), (3, 3))
        raise InputError(path, f"must be symmetric: [{i}][{j}] = {m[i, j]:g} but [{j}][{i}] = {m[j, i]:g}")
    m = (m + m.T) / 2
    principal = np.linalg.eigvalsh(m)
    if principal[0] <= 0:
        raise InputError(path, f"must be positive definite, its smallest principal moment is {principal[0]:g}")
    try:
        check_principal_inertia(principal, path)
    except InputError as exc:
        raise InputError(path, f"principal moments {np.round(principal, 9).tolist()}: {exc.reason}") from None
    return m
