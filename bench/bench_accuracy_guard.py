"""The accuracy guard's cost: the same runs with the guard on and off, side by side.

    python bench/bench_accuracy_guard.py [--repeat N] [SCENARIO ...]

Each scenario runs N times (default REPEATS) each way, interleaved, and the best wall times and
the best CPU times of the process are compared (docs/theory/accuracy.md, "Cost"; the goal is at
most 2 % of a run). On a shared virtual machine the wall time of one run moves by 10 % from
repeat to repeat: the CPU time, and more repeats, say more.
"""

from __future__ import annotations

import sys
import time

from testbed.runner import run_scenario
from testbed.scenario.loading import load_scenario

REPEATS = 3
DEFAULT = ["reorient_minimax", "lebedev_spinup_cmg", "cmg_open_loop", "torque_free_tumble"]


def _timed(name: str, overrides: list[str]) -> tuple[float, float]:
    """(wall, CPU) seconds of one run."""
    scenario = load_scenario(name, overrides)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    run_scenario(scenario, None)
    return time.perf_counter() - wall0, time.process_time() - cpu0


def main(names: list[str], repeats: int) -> None:
    print("| scenario | guard on [s] wall / CPU | guard off [s] wall / CPU | cost wall | cost CPU |")
    print("|---|---:|---:|---:|---:|")
    for name in names:
        on, off = [], []
        for _ in range(repeats):  # interleaved: a load change on the machine hits both alike
            on.append(_timed(name, []))
            off.append(_timed(name, ["accuracy.enabled=false"]))
        (wall_on, cpu_on), (wall_off, cpu_off) = [[min(t[i] for t in runs) for i in (0, 1)] for runs in (on, off)]
        print(f"| {name} | {wall_on:.3f} / {cpu_on:.3f} | {wall_off:.3f} / {cpu_off:.3f} | "
              f"{100 * (wall_on / wall_off - 1):+.1f} % | {100 * (cpu_on / cpu_off - 1):+.1f} % |", flush=True)


if __name__ == "__main__":
    args = sys.argv[1:]
    repeats = REPEATS
    if args[:1] == ["--repeat"]:
        repeats, args = int(args[1]), args[2:]
    main(args or DEFAULT, repeats)
