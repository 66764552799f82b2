"""Checks of the arguments every steering law shares; bad input raises InputError."""

from __future__ import annotations

import math

import numpy as np

from testbed.errors import InputError
from testbed.math.validation import positive_number


MIN_UNITS, MAX_UNITS = 3, 8  # the clusters a law steers: 3 ... 8 units


def checked_problem(J, h, Hdot, beta_rate_max):
    """Return (J as 3 lists of n floats, h, [Hx, Hy, Hz], beta_rate_max) or raise InputError;
    n, the number of units, is 3 ... 8.

    Plain Python floats on purpose: the closed-form min-max law works on them directly and
    this costs about a microsecond, less than the equivalent numpy checks.
    """
    if (type(J) is np.ndarray and J.ndim == 2 and J.shape[0] == 3 and MIN_UNITS <= J.shape[1] <= MAX_UNITS
            and J.dtype.kind in "fiu"):
        rows = J.astype(float, copy=False).tolist()  # fast path: the usual caller
    else:
        rows = _float_rows(J)
    # A sum is finite only if every term is (nan/inf propagate); entries are O(1), no overflow.
    if rows is None or not math.isfinite(sum(rows[0]) + sum(rows[1]) + sum(rows[2])):
        raise InputError("steering.J", f"must be a 3xn matrix of finite numbers, n = {MIN_UNITS} ... {MAX_UNITS}")
    try:
        hdot = [float(Hdot[0]), float(Hdot[1]), float(Hdot[2])] if len(Hdot) == 3 else []
    except (TypeError, ValueError, IndexError, KeyError):
        hdot = []
    if not hdot or not math.isfinite(hdot[0] + hdot[1] + hdot[2]):
        raise InputError("steering.Hdot", "must be 3 finite numbers")
    h = positive_number("steering.h", h, allow_inf=False)
    beta_rate_max = positive_number("steering.beta_rate_max", beta_rate_max, allow_inf=True)
    return rows, h, hdot, beta_rate_max


def _float_rows(J) -> list[list[float]] | None:
    """J as 3 lists of n floats (3 <= n <= 8), or None if it is not such an array of numbers."""
    try:
        rows = [[float(v) for v in r] for r in J]
    except (TypeError, ValueError):
        return None
    if len(rows) != 3 or not MIN_UNITS <= len(rows[0]) <= MAX_UNITS:
        return None
    return rows if all(len(r) == len(rows[0]) for r in rows) else None


def checked_rate_bounds(rate_bounds, beta_rate_max: float, units: int) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi), each (units,): per-gimbal rate bounds intersected with +-beta_rate_max; None means
    +-beta_rate_max alone. Refuses anything but two rows of `units` numbers with lo <= hi (InputError)."""
    limit = np.full(units, beta_rate_max)
    if rate_bounds is None:
        return -limit, limit
    try:
        bounds = np.asarray(rate_bounds, dtype=float)
    except (TypeError, ValueError):
        bounds = np.empty(0)
    if bounds.shape != (2, units) or np.any(np.isnan(bounds)) or np.any(bounds[0] > bounds[1]):
        raise InputError("steering.rate_bounds", f"must be (lo, hi), {units} numbers each, with lo <= hi")
    lo, hi = np.maximum(bounds[0], -limit), np.minimum(bounds[1], limit)
    if np.any(lo > hi):
        raise InputError("steering.rate_bounds", "a gimbal's bounds lie outside +-beta_rate_max")
    return lo, hi
