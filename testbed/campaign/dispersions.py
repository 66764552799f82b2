"""Distributions of a scenario field in a sweep or a Monte Carlo campaign (testbed.campaign.spec).

One mapping per field, exactly one kind:

    normal: [mean, sigma]                      sigma >= 0
    truncated_normal: [mean, sigma, low, high] the normal restricted to [low, high]; sigma > 0
    uniform: [low, high]                       [low, high), low < high
    log_uniform: [low, high]                   log of the value uniform; 0 < low < high
    integer: [low, high]                       equally likely integers low ... high (inclusive)
    choice: [a, b, ...]                        one of the values (any YAML), equally likely
    misalignment_deg: sigma                    a unit vector turned by an angle ~ N(0, sigma)
                                               about a random axis perpendicular to it
    uniform_direction: true                    a unit vector uniform on the sphere

The numeric kinds (normal ... integer) draw one value per component when the field's nominal
value is a list (`size: N` says how many when it has none), and may be applied to the nominal:
`relative: true` gives nominal * (1 + draw) (inertia +-5 % per axis: `{uniform: [-0.05, 0.05],
relative: true}`), `offset: true` gives nominal + draw. The nominal is the value the base
scenario has for the field (its default when the file does not set it).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from testbed.scenario import schema
from testbed.errors import InputError
from testbed.math.quaternion import quat_from_axis_angle, quat_rotate
from testbed.scenario.schema import param

# components a `size:` may ask for: each becomes a column of the campaign's table (one cell per
# case, testbed.campaign.rows.flat), so MAX_SIZE x MAX_CASES cells bound the table; the longest
# vector a scenario field takes has 6 components
MAX_SIZE = 1000
NUMERIC = ("normal", "truncated_normal", "uniform", "log_uniform", "integer")
KINDS = NUMERIC + ("choice", "misalignment_deg", "uniform_direction")


@dataclass(kw_only=True)
class Dispersion:
    """One field's distribution (see the module doc): exactly one kind, plus modifiers."""

    normal: list[float] | None = param(None, length=2, doc="[mean, sigma]")
    truncated_normal: list[float] | None = param(None, length=4, doc="[mean, sigma, low, high]")
    uniform: list[float] | None = param(None, length=2, doc="[low, high)")
    log_uniform: list[float] | None = param(None, length=2, gt=0, doc="[low, high), log-uniform")
    integer: list[int] | None = param(None, length=2, doc="[low, high] inclusive")
    choice: list[Any] | None = param(None, doc="equally likely values")
    misalignment_deg: float | None = param(None, ge=0, doc="1-sigma rotation angle of a unit vector")
    uniform_direction: bool | None = param(None, doc="a unit vector uniform on the sphere")
    relative: bool = param(False, doc="value = nominal * (1 + draw), per component")
    offset: bool = param(False, doc="value = nominal + draw, per component")
    size: int | None = param(None, ge=1, le=MAX_SIZE, doc="components to draw when the field has no nominal list")

    def validate(self, path: str) -> None:
        given = [name for name in KINDS if getattr(self, name) is not None]
        if len(given) != 1:
            raise InputError(path, f"give exactly one of {', '.join(KINDS)}")
        (self.kind,) = given
        values = getattr(self, self.kind)
        where = schema.join(path, self.kind)
        if self.kind == "choice" and not values:
            raise InputError(where, "needs at least one value")
        if self.kind == "uniform_direction" and not values:
            raise InputError(where, "must be true (or leave it out)")
        if self.kind in ("normal", "truncated_normal"):
            sigma = values[1]
            if sigma < 0 or (self.kind == "truncated_normal" and sigma == 0):
                raise InputError(where, f"sigma must be {'> 0' if self.kind == 'truncated_normal' else '>= 0'}, "
                                        f"got {sigma:g}")
        bounds = values[2:] if self.kind == "truncated_normal" else values
        if self.kind in ("truncated_normal", "uniform", "log_uniform", "integer") and bounds[0] >= bounds[1]:
            raise InputError(where, f"low {bounds[0]:g} must be < high {bounds[1]:g}")
        if self.kind in ("truncated_normal", "uniform", "log_uniform") and not math.isfinite(bounds[1] - bounds[0]):
            raise InputError(where, "its width high - low overflows: narrow it")
        if self.relative and self.offset:
            raise InputError(schema.join(path, "relative"), "give relative or offset, not both")
        if (self.relative or self.offset or self.size is not None) and self.kind not in NUMERIC:
            modifier = "relative" if self.relative else "offset" if self.offset else "size"
            raise InputError(schema.join(path, modifier), f"applies to {', '.join(NUMERIC)}, not {self.kind}")

    def draw(self, rng: np.random.Generator, nominal: Any, path: str = ""):
        """One value of the field: a number, a list of numbers (per component, or a unit
        vector) or one of the choices; `nominal` is the base scenario's value of the field."""
        if self.kind == "choice":
            return copy.deepcopy(self.choice[int(rng.integers(len(self.choice)))])
        if self.kind == "uniform_direction":
            direction = rng.standard_normal(3)
            return (direction / np.linalg.norm(direction)).tolist()
        if self.kind == "misalignment_deg":
            return misaligned(_unit_nominal(nominal, path), np.radians(self.misalignment_deg), rng).tolist()
        vector = isinstance(nominal, (list, tuple))
        if vector and not nominal and self.size is None:  # len 0 would draw an empty list: nothing
            raise InputError(path, "its nominal value is an empty list, so there are no components to "
                                   "draw; give size: N")
        count = self.size or (len(nominal) if vector else None)
        if (self.relative or self.offset) and not _is_numeric(nominal, count):
            raise InputError(path, f"{'relative' if self.relative else 'offset'} needs a numeric nominal value "
                                   f"in the scenario, got {nominal!r}")
        draws = self._numeric(rng, count)
        if self.relative:
            draws = np.asarray(nominal, float) * (1.0 + np.asarray(draws))
        elif self.offset:
            draws = np.asarray(nominal, float) + np.asarray(draws)
        if isinstance(draws, np.ndarray):
            return draws.tolist()
        return draws

    def _numeric(self, rng: np.random.Generator, count: int | None):
        """`count` draws of the numeric kind as a list (None: one plain number)."""
        kind, values = self.kind, getattr(self, self.kind)
        if kind == "normal":
            x = rng.normal(values[0], values[1], count)
        elif kind == "truncated_normal":
            mean, sigma, low, high = values
            from scipy import stats  # on use: at the top it would cost every command start-up time
            x = stats.truncnorm.rvs((low - mean) / sigma, (high - mean) / sigma, loc=mean, scale=sigma,
                                    size=count, random_state=rng)
        elif kind == "uniform":
            x = rng.uniform(values[0], values[1], count)
        elif kind == "log_uniform":
            x = np.exp(rng.uniform(np.log(values[0]), np.log(values[1]), count))
        else:
            x = rng.integers(values[0], values[1], count, endpoint=True)
            return int(x) if count is None else [int(v) for v in x]
        return float(x) if count is None else [float(v) for v in x]


def misaligned(axis: np.ndarray, sigma_rad: float, rng: np.random.Generator) -> np.ndarray:
    """`axis` (unit) turned by theta ~ N(0, sigma) about the unit axis u = cos(phi) e1 + sin(phi) e2
    perpendicular to it, phi uniform in [0, 2 pi): the angle between the result and `axis` is |theta|."""
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]  # the coordinate axis least aligned with `axis`
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    phi = rng.uniform(0.0, 2.0 * np.pi)
    theta = rng.normal(0.0, sigma_rad)
    return quat_rotate(quat_from_axis_angle(np.cos(phi) * e1 + np.sin(phi) * e2, theta), axis)


def angle_deg(a, b) -> float:
    """The angle between two 3-vectors [deg] (atan2 of |a x b| and a . b: exact for small angles)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b)), a @ b)))


def _unit_nominal(nominal, path: str) -> np.ndarray:
    if not _is_numeric(nominal, 3):
        raise InputError(path, f"misalignment_deg needs a 3-vector nominal value in the scenario, got {nominal!r}")
    vector = np.asarray(nominal, float)
    return vector / np.linalg.norm(vector)


def _is_numeric(value, count: int | None) -> bool:
    """A number (count None) or a list of `count` numbers."""
    if count is None:
        return schema.is_number(value)
    return isinstance(value, (list, tuple)) and len(value) == count and all(map(schema.is_number, value))
