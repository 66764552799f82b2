"""The `sweep:` block of a scenario: its schema, the seeds and the drawn values of each case.

    sweep:
      seed: 7                      # every draw is reproducible from it
      grid:                        # Cartesian product over dotted scenario paths
        pipeline.law.beta11: [1, 4]
        pipeline.law.k: [1, 4]
      dispersions:                 # drawn `samples` times for every grid point, each case from its own seed
        model.inertia_kg_m2: {uniform: [-0.05, 0.05], relative: true}
        pipeline.sensor.axis: {misalignment_deg: 0.5}
      random:                      # the same distributions, drawn from one stream in case order
        pipeline.law.beta22: {uniform: [0, 8]}
      samples: 3

The distributions are those of testbed.campaign.dispersions. Cases = grid points x samples (a grid
alone: its points; draws alone: `samples` cases), numbered in that order from 0: case i is
sample j = i mod samples of grid point i div samples. Its seed is `case_seed(seed, j)`, and
each dispersed field draws from a generator of its own, `field_generator(case seed, path)`:
a case is made from (seed, i) alone, so `testbed sweep --case i` rebuilds it without the
others; adding a field leaves the other fields' draws unchanged; and sample j draws the same
values at every grid point (common random numbers: a grid of designs, steering laws say, is
compared on the same dispersed cases, pair by pair). `random:` is the sweep's first form,
kept so that an existing seeded sweep gives the same cases: one generator seeded with `seed`
draws every case's fields in case order.

At most MAX_CASES cases: each is validated before the first runs.
"""

from __future__ import annotations

import itertools
import math
import zlib
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from testbed.scenario import schema
from testbed.campaign.dispersions import Dispersion
from testbed.errors import InputError
from testbed.scenario.schema import param

MAX_CASES = 10_000  # every case is validated before the first runs; campaigns beyond this are split
PARTS = ("grid", "dispersions", "random")


@dataclass(kw_only=True)
class SweepSpec:
    grid: dict[str, list[Any]] = param({})
    dispersions: dict[str, Dispersion] = param({}, doc="each case draws from its own seed")
    random: dict[str, Dispersion] = param({}, doc="one stream of draws in case order")
    samples: int | None = param(None, ge=1, doc="draws per grid point")
    seed: int = param(0, ge=0)

    def validate(self, path: str) -> None:
        if not self.grid and not self.drawn:
            raise InputError(path or "sweep", "is empty: give grid, dispersions and/or random fields")
        for key, values in self.grid.items():
            if not values:
                raise InputError(schema.join(schema.join(path, "grid"), key), "needs at least one value")
        if self.drawn and self.samples is None:
            raise InputError(schema.join(path, "samples"), "is required with dispersions or random fields")
        if not self.drawn and self.samples is not None:
            raise InputError(schema.join(path, "samples"), "needs dispersions or random fields to draw")
        seen: dict[str, str] = {}
        for part in PARTS:
            for key in getattr(self, part):
                where = schema.join(schema.join(path, part), key)
                if key.split(".")[0] == "sweep" or not all(key.split(".")):
                    raise InputError(where, "is not a scenario field")
                if key in seen:
                    raise InputError(where, f"is in {seen[key]} too")
                seen[key] = part
        cases = self.count
        if cases > MAX_CASES:
            raise InputError(path or "sweep", f"makes {cases:.3g} cases; at most {MAX_CASES}: "
                                              "fewer grid values or samples")

    @property
    def drawn(self) -> dict[str, Dispersion]:
        return self.dispersions | self.random

    @property
    def fields(self) -> list[str]:
        return list(self.grid) + list(self.dispersions) + list(self.random)

    @property
    def count(self) -> int:
        """How many cases the block makes."""
        return math.prod(len(values) for values in self.grid.values()) * (self.samples or 1)

    def part_of(self, key: str) -> str:
        return next(part for part in PARTS if key in getattr(self, part))


def load_spec(data, path: str = "sweep") -> SweepSpec:
    if data is None:
        raise InputError(path, "the scenario has no sweep block")
    return schema.load(SweepSpec, data, path)


def case_seed(seed: int, sample: int) -> int:
    """The seed of sample `sample`'s cases, in [0, 2^32): the first word of numpy's
    SeedSequence of the campaign seed spawned at key (sample,) (independent streams)."""
    return int(np.random.SeedSequence(seed, spawn_key=(sample,)).generate_state(1)[0])


def field_generator(seed_of_case: int, path: str) -> np.random.Generator:
    """The generator a case's dispersed field draws from: the case seed spawned at the CRC-32
    of the field's path, so a field's draws do not depend on the other fields."""
    return np.random.default_rng(np.random.SeedSequence(seed_of_case, spawn_key=(zlib.crc32(path.encode()),)))


def grid_points(spec: SweepSpec) -> list[dict[str, Any]]:
    """The grid points as {field: value}, in order (one empty point without a grid)."""
    return [dict(zip(spec.grid, combo)) for combo in itertools.product(*spec.grid.values())]


def stream_draws(spec: SweepSpec, nominal: Callable[[str], Any]) -> list[dict[str, Any]]:
    """The `random:` values of every case, {field: value}: one generator seeded with `seed`
    draws the fields of case 0, then of case 1, ... (nominal(path): the base scenario's value)."""
    rng = np.random.default_rng(spec.seed)
    return [{key: dist.draw(rng, nominal(key), f"sweep.random.{key}") for key, dist in spec.random.items()}
            for _ in range(spec.count)]


class CaseDraw:
    """The values of case `index`: its grid point, its `random:` values (`streamed`) and its
    dispersions, each field drawing from its own generator; `redraw(key)` takes that field's
    next draw (testbed.campaign.cases does, for a draw the field refuses)."""

    def __init__(self, spec: SweepSpec, index: int, point: dict, streamed: dict, nominal: Callable[[str], Any],
                 seed: int | None = None):
        self.spec, self.index, self.nominal = spec, index, nominal
        # the same for sample j at every grid point; `seed`: a case seed given outright (testbed.stepping)
        self.seed = case_seed(spec.seed, index % (spec.samples or 1)) if seed is None else seed
        self.generators = {key: field_generator(self.seed, key) for key in spec.dispersions}
        self.values = point | {key: self._draw(key) for key in spec.dispersions} | streamed

    def _draw(self, key: str):
        return self.spec.dispersions[key].draw(self.generators[key], self.nominal(key), f"sweep.dispersions.{key}")

    def redraw(self, key: str) -> None:
        self.values[key] = self._draw(key)


def case_draws(spec: SweepSpec, nominal: Callable[[str], Any] = lambda path: None,
               indices=None) -> list[CaseDraw]:
    """CaseDraw of every case (or of `indices`), in case order."""
    streams = stream_draws(spec, nominal) if spec.random else [{}] * spec.count
    points = grid_points(spec)
    return [CaseDraw(spec, i, points[i // (spec.samples or 1)], streams[i], nominal)
            for i in (range(spec.count) if indices is None else indices)]


def assignments(spec: SweepSpec, nominal: Callable[[str], Any] = lambda path: None) -> list[dict[str, Any]]:
    """The first-drawn values of every case, {field: value}, grid point (in order) x draws."""
    return [draw.values for draw in case_draws(spec, nominal)]
