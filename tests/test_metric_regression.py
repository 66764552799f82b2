"""Every shipped scenario's metrics, pinned: a refactor must reproduce them to 1e-12 relative.

The pinned values were produced by this file (`python tests/test_metric_regression.py`
rewrites tests/data/pinned_metrics.json); regenerate only for a change that is meant to
alter the physics or a metric's definition, and say so in the commit.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest

from testbed.runner import run_scenario
from testbed.scenario import load_scenario
from testbed.shipped_files import SCENARIO_DIR

PINNED = Path(__file__).with_name("data") / "pinned_metrics.json"
# Shortened where the full run is long; the rest run in full.
SHORTENED_S = {"cmg_open_loop": 60.0}
RTOL = 1e-12


def scenario_names() -> list[str]:
    return sorted(p.stem for p in SCENARIO_DIR.glob("*.yaml"))


def measure(name: str) -> dict[str, float]:
    overrides = [f"sim.duration_s={SHORTENED_S[name]}"] if name in SHORTENED_S else []
    result = run_scenario(load_scenario(name, overrides), None)
    assert result.status == "ok", result.error
    return result.metrics


def test_every_scenario_is_pinned():
    assert sorted(json.loads(PINNED.read_text())) == scenario_names()


@pytest.mark.slow
@pytest.mark.parametrize("name", scenario_names())
def test_metrics_unchanged(name):
    pinned = json.loads(PINNED.read_text())[name]
    measured = measure(name)
    assert sorted(measured) == sorted(pinned)
    for key, value in pinned.items():
        got = measured[key]
        if value is None or (isinstance(value, float) and math.isnan(value)):
            assert math.isnan(got), key
        else:
            assert got == pytest.approx(value, rel=RTOL, abs=0.0), key


if __name__ == "__main__":
    names = sys.argv[1:] or scenario_names()
    table = json.loads(PINNED.read_text()) if PINNED.exists() else {}
    for name in names:
        table[name] = {k: (None if math.isnan(v) else v) for k, v in measure(name).items()}
        print(name, len(table[name]), "metrics")
    PINNED.write_text(json.dumps(dict(sorted(table.items())), indent=1, sort_keys=True) + "\n")
