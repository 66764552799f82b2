"""Sweeps and Monte Carlo campaigns: a scenario's `sweep:` block (testbed.campaign.spec) expanded
into one validated scenario per case, each value set on the scenario like `--set path=value`.

A drawn value that its field refuses (an inertia breaking the triangle inequality, say) is
drawn again from the same field's generator, so the case stays reproducible from its seed:
the distribution is truncated to the values the field accepts. That is allowed while it stays
small: when more than MAX_REFUSED_SHARE of a dispersed field's draws over the campaign are
refused, the campaign is refused (exit 2), because the drawn distribution would no longer be
the one asked for. A refused grid value, a refused `random:` draw (drawn from one stream,
it cannot be drawn again without moving every later case) and anything wrong in the base
scenario refuse the campaign at once.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from typing import Any, Callable

from testbed.campaign.dispersions import angle_deg
from testbed.errors import InputError, quoted
from testbed.campaign.applied_values import NotApplied
from testbed.scenario.loading import field_value, parse, set_field
from testbed.campaign.spec import CaseDraw, case_draws, load_spec

MAX_REFUSED_SHARE = 0.01   # of a dispersed field's draws over the campaign
MAX_REDRAWS = 100          # of one field in one case


@dataclass
class Case:
    index: int
    values: dict[str, Any]   # field path -> value
    data: dict               # the raw scenario mapping with the values applied
    source: str = ""
    seed: int = 0            # the case's own seed (testbed.campaign.spec.case_seed)
    derived: dict[str, float] = field(default_factory=dict)  # e.g. a misalignment angle [deg]
    prepared: Any = None     # what `check` returned when it validated the case

    @property
    def label(self) -> str:
        return ", ".join(f"{k}={quoted(v)}" for k, v in self.values.items())


def expand(data: dict, source: str = "", check: Callable | None = None, indices=None) -> list[Case]:
    """Validate the sweep block of raw scenario `data` and every case it makes (see module doc);
    `check(scenario, values)` validates a parsed case further (e.g. builds it and reads back the
    values, raising testbed.campaign.applied_values.NotApplied for one that did not arrive; what it returns is
    kept as `Case.prepared`); `indices`
    builds only those cases (the refused share is then not judged)."""
    spec = load_spec(data.get("sweep"))
    base = {k: v for k, v in data.items() if k != "sweep"}
    nominal = _nominal(base, source)
    tally = {key: {"draws": 0, "refused": 0, "reason": ""} for key in spec.dispersions}
    cases = [_validated(draw, base, source, spec, check, tally) for draw in case_draws(spec, nominal, indices)]
    if indices is None:
        for key, count in tally.items():
            share = count["refused"] / max(count["draws"], 1)
            if share > MAX_REFUSED_SHARE:
                raise InputError(f"sweep.dispersions.{key}", f"{count['refused']} of its {count['draws']} draws "
                                 f"({share:.1%}) were refused, at most {MAX_REFUSED_SHARE:.0%} may be "
                                 f"(first: {count['reason']}); narrow the distribution or move its nominal")
    for case in cases:
        for key, dist in spec.dispersions.items():
            if dist.kind == "misalignment_deg":
                case.derived[f"{key}:misalignment_deg"] = angle_deg(case.values[key], nominal(key))
    return cases


def seeded_scenario(data: dict, source: str, seed: int):
    """The validated scenario of raw `data` whose dispersions draw from case seed `seed` (each
    field from its own generator, testbed.campaign.spec.field_generator, a refused draw drawn
    again as in a campaign); the grid and the `random:` fields keep the base scenario's values,
    and a scenario without a sweep block is itself."""
    if data.get("sweep") is None:
        return parse(copy.deepcopy(data), source)
    spec = load_spec(data["sweep"])
    base = {k: v for k, v in data.items() if k != "sweep"}
    tally = {key: {"draws": 0, "refused": 0, "reason": ""} for key in spec.dispersions}
    draw = CaseDraw(spec, 0, {}, {}, _nominal(base, source), seed=seed)
    return _validated(draw, base, source, spec, lambda scenario, values: scenario, tally).prepared


def _validated(draw, base: dict, source: str, spec, check, tally) -> Case:
    """The case of `draw`, its refused dispersions drawn again until it validates."""
    for key in spec.dispersions:
        tally[key]["draws"] += 1
    redraws = dict.fromkeys(spec.dispersions, 0)
    while True:
        data = copy.deepcopy(base)
        for key, value in draw.values.items():
            try:
                set_field(data, key, copy.deepcopy(value))
            except InputError as exc:
                raise InputError(f"sweep.{spec.part_of(key)}.{key}", exc.reason) from None
        try:
            scenario = parse(data, source)
            prepared = check(scenario, draw.values) if check is not None else None
            return Case(draw.index, dict(draw.values), data, source, draw.seed, prepared=prepared)
        except NotApplied as exc:
            key = _swept_field(exc.path, draw.values)
            raise InputError(f"sweep.{spec.part_of(key)}.{key}", f"case {draw.index}: the value set does not "
                                                                  f"reach the simulation: {exc}") from None
        except InputError as exc:
            key = _swept_field(exc.field, draw.values)
            if key not in spec.dispersions or redraws[key] >= MAX_REDRAWS:
                where = f"sweep.{spec.part_of(key)}.{key}" if key else "sweep"
                label = ", ".join(f"{k}={quoted(v)}" for k, v in draw.values.items())
                raise InputError(where, f"case {draw.index} ({label}): {exc.field}: {exc.reason}") from None
            tally[key]["refused"] += 1
            tally[key]["draws"] += 1
            tally[key]["reason"] = tally[key]["reason"] or f"{exc.field}: {exc.reason}"
            redraws[key] += 1
            draw.redraw(key)


def _swept_field(field_path: str, values: dict) -> str | None:
    """The swept field an error about `field_path` is about (the field, a part of it or a mapping above it)."""
    return next((k for k in values if field_path == k or field_path.startswith((k + ".", k + "["))
                 or k.startswith(field_path + ".")), None)


def _nominal(base: dict, source: str) -> Callable[[str], Any]:
    """path -> the base scenario's value of the field: the validated value (defaults included)
    when the base alone is a valid scenario, else what the file says (None if nothing)."""
    try:
        scenario = parse(copy.deepcopy(base), source)
    except InputError:
        scenario = None

    def raw(path: str):
        node = base
        for part in path.split("."):
            node = node.get(part) if isinstance(node, dict) else None
        return node

    def nominal(path: str):
        return copy.deepcopy(field_value(scenario, path, raw(path)) if scenario is not None else raw(path))

    return nominal
