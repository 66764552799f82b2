"""The `sweep:` block of a scenario: its schema and the values of each case.

    sweep:
      seed: 7                      # random draws are reproducible
      grid:                        # Cartesian product over dotted scenario paths
        pipeline.law.beta11: [1, 4]
        pipeline.law.k: [1, 4]
      random:                      # drawn `samples` times for every grid point
        model.inertia_kg_m2: {log_uniform: [0.5, 5]}
        pipeline.law.beta22: {uniform: [0, 8]}    # or {choice: [...]}, {integer: [lo, hi]}
      samples: 3

Cases = grid points x samples (a grid alone: its points; random alone: `samples` draws).
Every value is applied to the scenario's raw mapping with `scenario.apply_override`, exactly
like `--set path=value`, and every case is validated like a file before anything runs: a
bad value or an unknown field refuses the whole sweep with one line naming the field.
`testbed run` of such a file runs the base scenario (the sweep block is ignored there).
"""

from __future__ import annotations

import copy
import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from testbed import schema
from testbed.errors import InputError
from testbed.schema import param

DISTRIBUTIONS = ("uniform", "log_uniform", "choice", "integer")
MAX_CASES = 10_000  # every case is validated before the first runs; campaigns beyond this are split


@dataclass(kw_only=True)
class RandomField:
    """One distribution: exactly one of the keys."""

    uniform: list[float] | None = param(None, length=2, doc="[low, high)")
    log_uniform: list[float] | None = param(None, length=2, gt=0, doc="[low, high), log-uniform")
    choice: list[Any] | None = param(None, doc="equally likely values")
    integer: list[int] | None = param(None, length=2, doc="[low, high] inclusive")

    def validate(self, path: str) -> None:
        given = [name for name in DISTRIBUTIONS if getattr(self, name) is not None]
        if len(given) != 1:
            raise InputError(path, f"give exactly one of {', '.join(DISTRIBUTIONS)}")
        (self.kind,) = given
        values = getattr(self, self.kind)
        if self.kind == "choice" and not values:
            raise InputError(schema.join(path, "choice"), "needs at least one value")
        if self.kind != "choice" and values[0] > values[1]:
            raise InputError(schema.join(path, self.kind), f"low {values[0]:g} > high {values[1]:g}")
        if self.kind != "choice" and not math.isfinite(values[1] - values[0]):
            raise InputError(schema.join(path, self.kind), "its width high - low overflows: narrow it")
        if self.kind == "log_uniform" and values[0] <= 0:
            raise InputError(schema.join(path, self.kind), f"needs low > 0, got {values[0]:g}")

    def draw(self, rng: np.random.Generator):
        lo_hi = getattr(self, self.kind)
        if self.kind == "uniform":
            return float(rng.uniform(*lo_hi))
        if self.kind == "log_uniform":
            return float(np.exp(rng.uniform(np.log(lo_hi[0]), np.log(lo_hi[1]))))
        if self.kind == "integer":
            return int(rng.integers(lo_hi[0], lo_hi[1], endpoint=True))
        return copy.deepcopy(lo_hi[int(rng.integers(len(lo_hi)))])


@dataclass(kw_only=True)
class SweepSpec:
    grid: dict[str, list[Any]] = param({})
    random: dict[str, RandomField] = param({})
    samples: int | None = param(None, ge=1, doc="random draws per grid point")
    seed: int = param(0, ge=0)

    def validate(self, path: str) -> None:
        if not self.grid and not self.random:
            raise InputError(path or "sweep", "is empty: give grid and/or random fields")
        for key, values in self.grid.items():
            if not values:
                raise InputError(schema.join(schema.join(path, "grid"), key), "needs at least one value")
        if self.random and self.samples is None:
            raise InputError(schema.join(path, "samples"), "is required with random fields")
        if not self.random and self.samples is not None:
            raise InputError(schema.join(path, "samples"), "needs random fields to draw")
        for part in ("grid", "random"):
            for key in getattr(self, part):
                if key.split(".")[0] == "sweep" or not all(key.split(".")):
                    raise InputError(schema.join(schema.join(path, part), key), "is not a scenario field")
        both = set(self.grid) & set(self.random)
        if both:
            raise InputError(schema.join(path, "random"), f"{sorted(both)[0]} is in grid too")
        cases = math.prod(len(values) for values in self.grid.values()) * (self.samples or 1)
        if cases > MAX_CASES:
            raise InputError(path or "sweep", f"makes {cases:.3g} cases; at most {MAX_CASES}: "
                                              "fewer grid values or samples")

    @property
    def fields(self) -> list[str]:
        return list(self.grid) + list(self.random)


def load_spec(data, path: str = "sweep") -> SweepSpec:
    if data is None:
        raise InputError(path, "the scenario has no sweep block")
    return schema.load(SweepSpec, data, path)


def assignments(spec: SweepSpec) -> list[dict[str, Any]]:
    """The cases as {field: value}, grid points (in order) x random draws (seeded)."""
    rng = np.random.default_rng(spec.seed)
    points = [dict(zip(spec.grid, combo)) for combo in itertools.product(*spec.grid.values())]
    if not spec.random:
        return points
    return [point | {key: dist.draw(rng) for key, dist in spec.random.items()}
            for point in points for _ in range(spec.samples)]
