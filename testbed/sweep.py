"""Parameter sweeps: a scenario's `sweep:` block (testbed.sweep_spec) expanded into one
validated scenario per case, each value applied like `--set path=value`."""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any

import yaml

from testbed.errors import InputError
from testbed.scenario import apply_override, parse
from testbed.sweep_spec import assignments, load_spec


@dataclass
class Case:
    index: int
    values: dict[str, Any]   # field path -> value
    data: dict               # the raw scenario mapping with the values applied
    source: str = ""

    @property
    def label(self) -> str:
        return ", ".join(f"{k}={v}" for k, v in self.values.items())


def expand(data: dict, source: str = "") -> list[Case]:
    """Validate the sweep block of raw scenario `data` and every case it makes (see module doc)."""
    spec = load_spec(data.get("sweep"))
    base = {k: v for k, v in data.items() if k != "sweep"}
    cases = []
    for i, values in enumerate(assignments(spec)):
        case = copy.deepcopy(base)
        for key, value in values.items():
            part = "grid" if key in spec.grid else "random"
            text = yaml.safe_dump(value, default_flow_style=True, width=1e9).strip()
            if text.endswith("..."):      # safe_dump ends a bare scalar with a document marker
                text = text[:-3].strip()
            try:
                apply_override(case, f"{key}={text}")
            except InputError as exc:
                raise InputError(f"sweep.{part}.{key}", exc.reason) from None
        try:
            parse(case, source)
        except InputError as exc:
            field = exc.field
            where = next((f"sweep.{'grid' if k in spec.grid else 'random'}.{k}" for k in values
                          if field == k or field.startswith(k + ".") or k.startswith(field + ".")), "sweep")
            raise InputError(where, f"case {i} ({', '.join(f'{k}={v}' for k, v in values.items())}): "
                                    f"{exc.field}: {exc.reason}") from None
        cases.append(Case(i, values, case, source))
    return cases
