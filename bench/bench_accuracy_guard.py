"""The accuracy guard's cost: the same runs with the guard on and off, side by side.

    python bench/bench_accuracy_guard.py [SCENARIO ...]

Each scenario runs REPEATS times each way, interleaved, and the best wall times are compared
(docs/theory/accuracy.md, "Cost"; the goal is at most 2 % of a run).
"""

from __future__ import annotations

import sys
import time

from testbed.runner import run_scenario
from testbed.scenario.loading import load_scenario

REPEATS = 3
DEFAULT = ["reorient_minimax", "lebedev_spinup_cmg", "cmg_open_loop", "torque_free_tumble"]


def _timed(name: str, overrides: list[str]) -> float:
    scenario = load_scenario(name, overrides)
    t0 = time.perf_counter()
    run_scenario(scenario, None)
    return time.perf_counter() - t0


def main(names: list[str]) -> None:
    print("| scenario | guard on [s] | guard off [s] | cost |")
    print("|---|---:|---:|---:|")
    for name in names:
        on, off = [], []
        for _ in range(REPEATS):  # interleaved: a load change on the machine hits both alike
            on.append(_timed(name, []))
            off.append(_timed(name, ["accuracy.enabled=false"]))
        print(f"| {name} | {min(on):.3f} | {min(off):.3f} | {100 * (min(on) / min(off) - 1):+.1f} % |", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:] or DEFAULT)
