"""How far round-off moves each pinned metric, and the tolerance class that follows (docs/validation.md,
"Testing: pinned numbers").

A pinned metric is re-measured under other floating-point kernels, chosen by hand in the shell
(never in tests or CI), e.g.

    python bench/pin_spread.py measure runs/spread_own.json
    OPENBLAS_CORETYPE=Haswell python bench/pin_spread.py measure runs/spread_haswell.json
    OPENBLAS_CORETYPE=Sandybridge python bench/pin_spread.py measure runs/spread_sandy.json
    NPY_DISABLE_CPU_FEATURES="AVX2 FMA3" python bench/pin_spread.py measure runs/spread_nosimd.json
    python bench/pin_spread.py classes runs/spread_*.json

`classes` prints, for every pin, the largest relative spread seen and the class it falls in,
and writes tests/data/pin_classes.json, which tests/test_metric_regression.py applies.
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))

from test_metric_regression import CLASSES, PINNED, TOLERANCES, class_of, measure, scenario_names  # noqa: E402


def relative_spread(pinned: float | None, got: float | None) -> float:
    """|got - pinned| / |pinned| (0 when both are NaN; inf when only one is)."""
    if pinned is None or got is None:
        return 0.0 if pinned is None and got is None else math.inf
    if pinned == got:
        return 0.0
    return abs(got - pinned) / abs(pinned) if pinned else math.inf


def cmd_measure(out: str, names: list[str]) -> None:
    table = {}
    for name in names or scenario_names():
        t0 = time.perf_counter()
        table[name] = {k: (None if math.isnan(v) else v) for k, v in measure(name).items()}
        print(f"{name}: {time.perf_counter() - t0:.1f} s", flush=True)
    Path(out).write_text(json.dumps(table, indent=1, sort_keys=True) + "\n")


def cmd_classes(files: list[str]) -> None:
    pinned = json.loads(PINNED.read_text())
    runs = {f: json.loads(Path(f).read_text()) for f in files}
    classes, rows = {}, []
    for scenario, metrics in sorted(pinned.items()):
        classes[scenario] = {}
        for metric, value in sorted(metrics.items()):
            spread = max((relative_spread(value, run[scenario][metric]) for run in runs.values()
                          if scenario in run), default=0.0)
            kind = class_of(metric, value, spread)
            classes[scenario][metric] = kind
            rows.append((spread, scenario, metric, value, kind))
    print(f"{'largest relative spread':>24s}  {'scenario':28s} {'metric':40s} {'value':>12s}  class (tolerance)")
    for spread, scenario, metric, value, kind in sorted(rows, key=lambda r: -r[0]):
        shown = "nan" if value is None else f"{value:12.4g}"
        print(f"{spread:24.2e}  {scenario:28s} {metric:40s} {shown:>12s}  {kind} ({TOLERANCES[kind]})")
    CLASSES.write_text(json.dumps(classes, indent=1, sort_keys=True) + "\n")
    print(f"wrote {CLASSES}")


if __name__ == "__main__":
    if len(sys.argv) < 3 or sys.argv[1] not in ("measure", "classes"):
        sys.exit(__doc__)
    if sys.argv[1] == "measure":
        cmd_measure(sys.argv[2], sys.argv[3:])
    else:
        cmd_classes(sys.argv[2:])
