"""Typed dataclass schemas for scenario files: load, default, and validate nested dicts.

A schema is a dataclass whose fields carry `param(...)` metadata (unit in the key name,
bounds, fixed vector length). `load(cls, data, path)` refuses unknown keys, wrong types and
values out of bounds with an `InputError` naming the dotted field path; a dataclass may add
cross-field checks in a `validate(self, path)` method.
"""

from __future__ import annotations

import dataclasses
import math
import types
import typing
from typing import Any, Literal, get_args, get_origin

from testbed.errors import InputError, quoted

_MISSING = dataclasses.MISSING

# Units are in the key names; a mass or an inertia must also lie where MuJoCo's compiler and
# the squares in the dynamics stay exact: from a gyro rotor's to far beyond a space station's.
UNIT_RANGES = {"_kg": (1e-6, 1e12), "_kg_m2": (1e-9, 1e12)}
# Every number a scenario gives is 0 or lies within these in magnitude: the product or square of
# two of them stays a normal double, so no parameter under- or overflows where it is first used
# (1e-300 arcsec squared is below the smallest double). Far beyond any physical figure here.
SMALLEST, LARGEST = 1e-100, 1e100


def param(default=_MISSING, *, gt=None, ge=None, lt=None, le=None, length=None, doc=""):
    """A schema field: default (a list default is copied per instance), bounds, vector length."""
    meta = {"gt": gt, "ge": ge, "lt": lt, "le": le, "length": length, "doc": doc}
    if isinstance(default, (list, dict)):
        value = default
        return dataclasses.field(default_factory=lambda: type(value)(value), metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _type_name(tp) -> str:
    if get_origin(tp) is Literal:
        return "one of " + ", ".join(repr(a) for a in get_args(tp))
    return getattr(tp, "__name__", str(tp))


def is_number(value) -> bool:
    """An int or float, not a bool (YAML's true/false are not numbers here)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _convert(tp, value, path: str, meta: dict):
    origin = get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        options = get_args(tp)
        if value is None and type(None) in options:
            return None
        for option in options:
            if option is type(None):
                continue
            return _convert(option, value, path, meta)
    if tp is Any:
        return value
    if origin is Literal:
        if value not in get_args(tp):
            raise InputError(path, f"must be {_type_name(tp)}, got {quoted(value)}")
        return value
    if dataclasses.is_dataclass(tp):
        return load(tp, value, path)
    if tp is float:
        if not is_number(value):
            raise InputError(path, f"must be a number, got {quoted(value)}")
        try:
            value = float(value)
        except OverflowError:  # an integer too large for a float
            raise InputError(path, f"must be finite, got {quoted(value)}") from None
        if not math.isfinite(value):
            raise InputError(path, f"must be finite, got {quoted(value)}")
        _check_bounds(value, path, meta)
        if value != 0 and not SMALLEST <= abs(value) <= LARGEST:
            raise InputError(path, f"must be 0 or lie within {SMALLEST:g} ... {LARGEST:g} in magnitude (products "
                             f"and squares of such numbers stay ordinary doubles), got {value:g}")
        return value
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise InputError(path, f"must be an integer, got {quoted(value)}")
        if abs(value) > 2**63 - 1:  # what numpy and the seeds can hold
            raise InputError(path, f"must lie within +-(2^63 - 1), a signed 64-bit integer, got {quoted(value)}")
        _check_bounds(value, path, meta)
        return value
    if tp is bool:
        if not isinstance(value, bool):
            raise InputError(path, f"must be true or false, got {quoted(value)}")
        return value
    if tp is str:
        if not isinstance(value, str):
            raise InputError(path, f"must be a string, got {quoted(value)}")
        return value
    if origin is list:
        (item_tp,) = get_args(tp)
        if not isinstance(value, (list, tuple)):
            raise InputError(path, f"must be a list, got {quoted(value)}")
        length = meta.get("length")
        if length is not None and len(value) != length:
            raise InputError(path, f"must have {length} elements, got {len(value)}")
        return [_convert(item_tp, v, f"{path}[{i}]", meta) for i, v in enumerate(value)]
    if origin is dict:
        if not isinstance(value, dict):
            raise InputError(path, f"must be a mapping, got {quoted(value)}")
        _, val_tp = get_args(tp)
        return {str(k): _convert(val_tp, v, join(path, str(k)), meta) for k, v in value.items()}
    raise TypeError(f"schema type {tp!r} at {path} is not supported")


def _check_unit_range(name: str, value, path: str) -> None:
    """Every number of a field whose name ends in a unit of UNIT_RANGES lies in its range."""
    suffix = next((u for u in sorted(UNIT_RANGES, key=len, reverse=True) if name.endswith(u)), None)
    if suffix is None or value is None:
        return
    low, high = UNIT_RANGES[suffix]
    for number in _numbers(value):
        if not low <= abs(number) <= high and number != 0:
            raise InputError(path, f"must lie in [{low:g}, {high:g}] in magnitude ({suffix[1:]}), got {number:g}")


def _numbers(value):
    if isinstance(value, (list, tuple)):
        for item in value:
            yield from _numbers(item)
    elif is_number(value):
        yield float(value)


def _check_bounds(value, path: str, meta: dict) -> None:
    for key, ok, word in (
        ("gt", lambda v, b: v > b, ">"),
        ("ge", lambda v, b: v >= b, ">="),
        ("lt", lambda v, b: v < b, "<"),
        ("le", lambda v, b: v <= b, "<="),
    ):
        bound = meta.get(key)
        if bound is not None and not ok(value, bound):
            raise InputError(path, f"must be {word} {bound}, got {value:g}")


def load(cls, data, path: str = ""):
    """Build dataclass `cls` from mapping `data`, validating every field (see module doc)."""
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise InputError(path or "scenario", f"must be a mapping, got {quoted(data)}")
    fields = {f.name: f for f in dataclasses.fields(cls) if f.init}
    for key in data:
        if key not in fields:
            known = ", ".join(sorted(fields))
            raise InputError(join(path, str(key)), f"unknown key (known: {known})")
    hints = typing.get_type_hints(cls)
    kwargs = {}
    for name, f in fields.items():
        fpath = join(path, name)
        if name in data:
            kwargs[name] = _convert(hints[name], data[name], fpath, dict(f.metadata))
            _check_unit_range(name, kwargs[name], fpath)
        elif f.default is _MISSING and f.default_factory is _MISSING:
            raise InputError(fpath, "is required")
    obj = cls(**kwargs)
    validate = getattr(obj, "validate", None)
    if validate is not None:
        validate(path)
    return obj


# The unit a key's name ends in (longest first), for `testbed describe` and the docs.
UNIT_SUFFIXES = {
    "_deg_s2": "deg/s^2", "_deg_s": "deg/s", "_deg": "deg", "_rad_s3": "rad/s^3", "_rad_s2": "rad/s^2",
    "_rad_s": "rad/s", "_rad": "rad", "_nms_rad": "N m s/rad", "_nm_rad": "N m/rad", "_nms": "N m s",
    "_nm": "N m", "_kg_m2": "kg m^2", "_kg_m": "kg m", "_kg": "kg", "_per_s": "1/s", "_1_s": "1/s", "_hz": "Hz",
    "_rpm": "rpm", "_m": "m", "_s": "s",
    "_rad_sqrt_s": "rad/s^(1/2)", "_rad_s_sqrt_s": "rad/s^(3/2)", "_arcsec": "arcsec", "_ppm": "ppm",
    "_deg_h": "deg/h", "_km": "km", "_am2": "A m^2", "_t": "T", "_sfu": "sfu",
}


def unit_of(name: str) -> str:
    """The unit a key's name ends in ("" for a dimensionless key)."""
    return next((UNIT_SUFFIXES[u] for u in sorted(UNIT_SUFFIXES, key=len, reverse=True) if name.endswith(u)), "")


def bounds_of(name: str, meta: dict) -> str:
    """The bounds `load` enforces on a field, as text: `>= 0, < 90`, a vector's length, a unit's range."""
    words = [f"{word} {meta[key]:g}" for key, word in (("gt", ">"), ("ge", ">="), ("lt", "<"), ("le", "<="))
             if meta.get(key) is not None]
    if meta.get("length") is not None:
        words.append(f"{meta['length']} elements")
    suffix = next((u for u in sorted(UNIT_RANGES, key=len, reverse=True) if name.endswith(u)), None)
    if suffix is not None:
        low, high = UNIT_RANGES[suffix]
        words.append(f"|x| in [{low:g}, {high:g}] or 0")
    return ", ".join(words)


def _shown_type(tp) -> str:
    """A field's type as a reader writes it: `list[float]`, `float | None`, `one of 'a', 'b'`."""
    origin, args = get_origin(tp), get_args(tp)
    if origin in (typing.Union, types.UnionType):
        return " | ".join(_shown_type(a) for a in args)
    if origin in (list, dict):
        return f"{origin.__name__}[{', '.join(_shown_type(a) for a in args)}]"
    return "None" if tp is type(None) else _type_name(tp)


def describe(cls, path: str = "") -> list[dict]:
    """One row per field of schema dataclass `cls` (nested dataclasses flattened to dotted
    paths): key, type, unit, default, bounds and meaning, from the same metadata `load`
    validates with."""
    rows = []
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        if not f.init:
            continue
        tp = hints[f.name]
        fpath = join(path, f.name)
        union = get_origin(tp) in (typing.Union, types.UnionType)
        optional = [a for a in get_args(tp) if a is not type(None)] if union else []
        if len(optional) == 1 and dataclasses.is_dataclass(optional[0]):  # an optional block: its fields
            rows.append({"key": fpath, "type": "mapping | None", "unit": "", "default": "None", "bounds": "",
                         "meaning": f.metadata.get("doc", "")})
            rows.extend(describe(optional[0], fpath))
            continue
        if dataclasses.is_dataclass(tp):
            rows.extend(describe(tp, fpath))
            continue
        if f.default is not _MISSING:
            default = repr(f.default)
        elif f.default_factory is not _MISSING:
            default = repr(f.default_factory())
        else:
            default = "required"
        rows.append({"key": fpath, "type": _shown_type(tp), "unit": unit_of(f.name), "default": default,
                     "bounds": bounds_of(f.name, dict(f.metadata)), "meaning": f.metadata.get("doc", "")})
        item = get_args(tp)[0] if get_origin(tp) is list else None
        if item is not None and dataclasses.is_dataclass(item):  # a list of records: each item's fields
            rows.extend(describe(item, f"{fpath}[]"))
    return rows


def whole_multiple(value: float, unit: float, path: str, unit_name: str) -> int:
    """How many `unit`s make `value`; refuses a value that is not a whole multiple."""
    ratio = value / unit
    if not math.isfinite(ratio) or ratio > 1e15:  # beyond any run's step count (and float's integers)
        raise InputError(path, f"{value:g} s is {ratio:.3g} times {unit_name} = {unit:g} s: far too many")
    n = round(ratio)
    if n < 1 or abs(n * unit - value) > 1e-9 * max(value, unit):
        raise InputError(path, f"must be a whole multiple of {unit_name} = {unit:g} s, got {value:g} s")
    return n
