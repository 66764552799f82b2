"""Checks of the arguments every steering law shares; bad input raises InputError."""

from __future__ import annotations

import math

import numpy as np

from testbed.errors import InputError


def checked_problem(J, h, Hdot, beta_rate_max):
    """Return (J as 3 lists of 4 floats, h, [Hx, Hy, Hz], beta_rate_max) or raise InputError.

    Plain Python floats on purpose: the closed-form min-max law works on them directly and
    this costs about a microsecond, less than the equivalent numpy checks.
    """
    if type(J) is np.ndarray and J.shape == (3, 4) and J.dtype.kind in "fiu":
        rows = J.astype(float, copy=False).tolist()  # fast path: the usual caller
    else:
        rows = _float_rows(J)
    # A sum is finite only if every term is (nan/inf propagate); entries are O(1), no overflow.
    if rows is None or not math.isfinite(sum(rows[0]) + sum(rows[1]) + sum(rows[2])):
        raise InputError("steering.J", "must be a 3x4 matrix of finite numbers")
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
    """J as 3 lists of 4 floats, or None if it is not a 3x4 array of numbers."""
    try:
        rows = [[float(v) for v in r] for r in J]
    except (TypeError, ValueError):
        return None
    return rows if len(rows) == 3 and all(len(r) == 4 for r in rows) else None


def positive_number(field: str, value, allow_inf: bool) -> float:
    """float(value) if it is > 0 (and finite unless allow_inf), else InputError(field, ...)."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(field, "must be a number > 0") from None
    if not x > 0:  # also catches nan
        raise InputError(field, "must be > 0")
    if not allow_inf and math.isinf(x):
        raise InputError(field, "must be finite")
    return x


def number_in(field: str, value, low: float, high: float, low_open=False, high_open=False) -> float:
    """float(value) if it lies in the interval [low, high] (ends open if asked), else InputError."""
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
