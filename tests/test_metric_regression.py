"""Every shipped scenario's metrics, pinned, each to a tolerance its round-off allows.

A pin's tolerance class (tests/data/pin_classes.json) says how far it may move (docs/validation.md,
"Testing: pinned numbers"): `bench/pin_spread.py` re-measures every pin under other
floating-point kernels (chosen by hand in the shell) and puts each in the tightest class
that allows 100 times the largest spread seen. A conserved quantity's drift, and any value
below RESIDUAL_BELOW, sits at the round-off floor whatever a few kernels show: always `floor`.

The pinned values were produced by this file (`python tests/test_metric_regression.py`
rewrites tests/data/pinned_metrics.json); regenerate only for a change that is meant to
alter the physics or a metric's definition, and say so in the commit with old and new values.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest

from testbed.runner import run_scenario
from testbed.scenario.loading import load_scenario
from testbed.scenario.shipped_files import SCENARIO_DIR

PINNED = Path(__file__).with_name("data") / "pinned_metrics.json"
CLASSES = Path(__file__).with_name("data") / "pin_classes.json"
# Shortened where the full run is long; the rest run in full.
SHORTENED_S = {"cmg_open_loop": 60.0, "orbit_momentum_buildup": 600.0,
               "orbit_momentum_management": 300.0, "orbit_momentum_campaign": 300.0}

# Largest relative spread (kernel to kernel) a class admits; each class's tolerance is 100x it.
TIGHT_SPREAD, AMPLIFIED_SPREAD = 1e-11, 1e-6
TIGHT_RTOL, AMPLIFIED_RTOL = 1e-9, 1e-4
# A floor metric is a residual at round-off (a drift, an exact law's torque error, an error
# against an exact reference): its value means "at the floor", whose height is the CPU's (an AMD
# EPYC against an Intel Xeon: a drift 3.1e-12 vs 6.1e-12, a pointing error 1.6e-11 vs 3.8e-11),
# so it may move by a factor FLOOR_FACTOR either way, which still catches a conservation lost by
# an order of magnitude; anything below FLOOR_ABS is the same zero (the tightest check bound is 1e-9).
FLOOR_FACTOR, FLOOR_ABS = 10.0, 1e-12
TOLERANCES = {"tight": f"rel {TIGHT_RTOL:g}", "amplified": f"rel {AMPLIFIED_RTOL:g}",
              "floor": f"a factor {FLOOR_FACTOR:g} either way, or both below {FLOOR_ABS:g}"}


# No metric here has a natural scale below this: a smaller value is a residual at the floor,
# however still a few kernels leave it.
RESIDUAL_BELOW = 1e-9


def class_of(metric: str, value: float | None, spread: float) -> str:
    """The tolerance class of a pin whose largest relative spread under other kernels is `spread`."""
    residual = value is not None and abs(value) < RESIDUAL_BELOW
    if metric.endswith("_drift_rel") or residual or spread > AMPLIFIED_SPREAD:
        return "floor"
    return "amplified" if spread > TIGHT_SPREAD else "tight"


def within(kind: str, pinned: float, got: float) -> bool:
    """Whether `got` is within the tolerance of class `kind` of `pinned`."""
    if kind == "floor":
        if max(abs(got), abs(pinned)) < FLOOR_ABS:
            return True
        return pinned * got > 0 and abs(pinned) / FLOOR_FACTOR <= abs(got) <= FLOOR_FACTOR * abs(pinned)
    return abs(got - pinned) <= (TIGHT_RTOL if kind == "tight" else AMPLIFIED_RTOL) * abs(pinned)


def scenario_names() -> list[str]:
    return sorted(p.stem for p in SCENARIO_DIR.glob("*.yaml"))


def measure(name: str) -> dict[str, float]:
    overrides = [f"sim.duration_s={SHORTENED_S[name]}"] if name in SHORTENED_S else []
    result = run_scenario(load_scenario(name, overrides), None)
    assert result.status == "ok", result.error
    return result.metrics


def test_every_scenario_is_pinned_and_every_pin_has_a_class():
    pinned = json.loads(PINNED.read_text())
    classes = json.loads(CLASSES.read_text())
    assert sorted(pinned) == scenario_names()
    for name, metrics in pinned.items():
        assert sorted(classes.get(name, {})) == sorted(metrics), name
        assert set(classes[name].values()) <= set(TOLERANCES), name


def test_the_classes_hold_what_they_say():
    """The tolerance test itself, on numbers whose answer is known."""
    assert within("tight", 1.0, 1.0 + 9e-10) and not within("tight", 1.0, 1.0 + 2e-9)
    assert within("amplified", -2.0, -2.0 + 1.9e-4) and not within("amplified", -2.0, -2.0 + 2.1e-4)
    assert within("floor", 4e-10, 3.9e-9) and not within("floor", 4e-10, 4.1e-9)
    assert within("floor", 4e-10, 4.1e-11) and not within("floor", 4e-10, 3.9e-11)
    assert not within("floor", 4e-10, -4e-10) and within("floor", 3e-16, 9e-13)
    assert class_of("momentum_drift_rel", 1e-10, 0.0) == "floor"
    assert class_of("min_scale", 0.2, 5.5e-10) == "amplified"
    assert class_of("akor_settling_time_s", 3.8, 0.0) == "tight"
    assert class_of("max_omega_error_rad_s", 4e-17, 0.0) == "floor"
    assert class_of("spin_error_final_deg_s", 2e-10, 0.04) == "floor"


@pytest.mark.slow
@pytest.mark.parametrize("name", scenario_names())
def test_metrics_unchanged(name):
    pinned = json.loads(PINNED.read_text())[name]
    classes = json.loads(CLASSES.read_text())[name]
    measured = measure(name)
    assert sorted(measured) == sorted(pinned)
    for key, value in pinned.items():
        got = measured[key]
        if value is None or (isinstance(value, float) and math.isnan(value)):
            assert math.isnan(got), key
        else:
            assert within(classes[key], value, got), (key, classes[key], value, got)


if __name__ == "__main__":
    names = sys.argv[1:] or scenario_names()
    table = json.loads(PINNED.read_text()) if PINNED.exists() else {}
    for name in names:
        table[name] = {k: (None if math.isnan(v) else v) for k, v in measure(name).items()}
        print(name, len(table[name]), "metrics")
    PINNED.write_text(json.dumps(dict(sorted(table.items())), indent=1, sort_keys=True) + "\n")
