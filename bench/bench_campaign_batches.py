"""A campaign in batches against its cases run one by one and against its bare physics.

    .venv/bin/python bench/bench_campaign_batches.py [SCENARIO] [--cases 32] [--duration 100]
                                                     [--workers 2] [--repeat 1] [--before DIR]

The first K cases of SCENARIO (default lebedev_spinup_campaign, the flagship's campaign), cut
to --duration simulated seconds, are measured four ways on this machine, side by side:
  - bare physics: each case's plant built, then `mj_step` over the run's steps in one call (no
    stage, no recorder: the floor a case cannot beat), summed over the cases;
  - one by one: each case's `run_case` in this process, summed (a single run's wall time);
  - the campaign command on --workers local workers (`testbed campaign ... --workers W`),
    as shipped (batched) and with `--batch-size 1` (each case a task of its own), alternated
    --repeat times (median); whole-process wall time, the cluster's start and every case's
    build and read-back included. With --before DIR (a checkout of another commit) the command
    runs from that tree instead of `--batch-size 1`.
Prints, per configuration, the campaign's wall against the sum of the single runs (goal < 1/W
of it plus the start), and its cost per case in CPU-equivalent time (wall x workers / cases)
over the bare physics per case (goal <= 1.3); then every case whose verdict or metrics differ
between the two configurations, beyond the lockstep tolerance of tests/test_batch_lockstep.py.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import mujoco

from testbed.campaign.orchestration import load_cases
from testbed.campaign.rows import run_case
from testbed.plugins import discover
from testbed.run_core.plan import prepare
from testbed.scenario.loading import parse

BATCHED_REL, ABS_FLOOR = 1e-9, 1e-13  # tests/test_batch_lockstep.py


def bare_physics_s(cases) -> float:
    """Sum over the cases of mj_step over each run's steps, in one call, on its built plant [s]."""
    total = 0.0
    for case in cases:
        plan = prepare(parse(case.data, case.source))
        steps = plan.timing.n_ticks * plan.timing.steps_per_tick
        start = time.perf_counter()
        mujoco.mj_step(plan.plant.model, plan.plant.data, steps)
        total += time.perf_counter() - start
    return total


def one_by_one_s(cases) -> float:
    """The cases' run_case one after another in this process [s] (the first one warmed)."""
    run_case(cases[0])
    start = time.perf_counter()
    for case in cases:
        run_case(case)
    return time.perf_counter() - start


def campaign(scenario: str, overrides: list[str], workers: int, out: Path, extra: list[str],
             tree: str | None) -> tuple[float, dict]:
    """(whole-process wall seconds, rows by case) of the campaign command run into `out`."""
    argv = [sys.executable, "-m", "testbed", "campaign", scenario, "--workers", str(workers), "--out", str(out),
            *[a for o in overrides for a in ("--set", o)], *extra]
    env = dict(os.environ, PYTHONPATH=tree) if tree else None
    start = time.perf_counter()
    done = subprocess.run(argv, capture_output=True, text=True, env=env, cwd=tree)
    wall = time.perf_counter() - start
    if done.returncode not in (0, 1):
        raise SystemExit(f"{' '.join(argv)} failed: {done.stderr.strip()[-2000:]}")
    with next(out.glob("*.csv")).open(newline="") as handle:
        return wall, {row["case"]: row for row in csv.DictReader(handle)}


def differences(a: dict, b: dict) -> list[str]:
    """The cells of two rows of one case that differ: status, verdicts, metrics beyond the tolerance."""
    found = []
    for key in a:
        x, y = a[key], b.get(key)
        if key in ("wall_s",) or x == y:
            continue
        try:
            fx, fy = float(x), float(y)
        except (TypeError, ValueError):
            found.append(f"{key}: {x} -> {y}")
            continue
        if not (math.isnan(fx) and math.isnan(fy)) and abs(fx - fy) > max(BATCHED_REL * abs(fx), ABS_FLOOR):
            found.append(f"{key}: {x} -> {y}")
    return found


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("scenario", nargs="?", default="lebedev_spinup_campaign")
    parser.add_argument("--cases", type=int, default=32)
    parser.add_argument("--duration", type=float, default=100.0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--before", metavar="DIR", help="a checkout of the commit to compare with")
    args = parser.parse_args()
    discover()
    overrides = [f"sim.duration_s={args.duration:g}", f"sweep.samples={args.cases}"]
    _, _, cases = load_cases(args.scenario, overrides)
    cases = cases[:args.cases]
    if len(cases) != args.cases:
        raise SystemExit(f"{args.scenario} has {len(cases)} cases with these overrides, not {args.cases}")
    bare = bare_physics_s(cases) / len(cases)
    single = one_by_one_s(cases)
    kinds = {"batched": ([], None), "before" if args.before else "batch-size 1":
             ([] if args.before else ["--batch-size", "1"], str(Path(args.before).resolve()) if args.before else None)}
    walls = {kind: [] for kind in kinds}
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.repeat):
            for kind, (extra, tree) in kinds.items():
                wall, rows[kind] = campaign(args.scenario, overrides, args.workers, Path(tmp) / f"{kind}{k}", extra,
                                            tree)
                walls[kind].append(wall)
    print(f"{args.scenario}: {len(cases)} cases of {args.duration:g} s on {args.workers} workers "
          f"(median of {args.repeat}); load average {os.getloadavg()[0]:.1f}")
    print(f"  bare physics   {bare * 1e3:8.1f} ms a case (mj_step over the run's steps)")
    print(f"  one by one     {single:8.2f} s for the {len(cases)} cases ({single / len(cases) / bare:.2f}x the bare "
          f"physics a case)")
    for kind, times in walls.items():
        wall = statistics.median(times)
        cpu_per_case = wall * args.workers / len(cases)
        print(f"  {kind:14s} {wall:8.2f} s wall: {wall / single:.3f} of the one-by-one sum, "
              f"{cpu_per_case / bare:.2f}x the bare physics a case (wall x {args.workers} workers / {len(cases)})")
    kinds_run = list(walls)
    first, second = rows[kinds_run[0]], rows[kinds_run[1]]
    changed = {case: differences(second[case], first[case]) for case in second}
    changed = {case: found for case, found in changed.items() if found}
    verdicts = sum(first[c]["passed"] != second[c]["passed"] for c in second)
    print(f"  {kinds_run[1]} -> {kinds_run[0]}: {verdicts} verdicts differ, {len(changed)} rows differ beyond "
          f"rel {BATCHED_REL:g} / abs {ABS_FLOOR:g}")
    for case, found in changed.items():
        print(f"    case {case}: {'; '.join(found[:4])}")


if __name__ == "__main__":
    main()
