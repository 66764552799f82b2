"""A campaign in batches against its cases run one by one and against its bare physics.

    .venv/bin/python bench/bench_campaign_batches.py [SCENARIO] [--cases 32] [--duration 100]
                                                     [--workers 2] [--repeat 1] [--command [--before DIR]]

The first K cases of SCENARIO (default lebedev_spinup_campaign, the flagship's campaign), cut
to --duration simulated seconds, are measured four ways on this machine, side by side:
  - bare physics: the CPU time of MuJoCo's steps of the cases' own runs (their worlds stepped
    in one batch in this process, the time inside the physics calls alone: the floor a case
    cannot beat). Not `mj_step` over the run's steps in one call, printed beside it: without
    the run's commands the state stays near its start, where the steps cost up to 1.7 times
    more (measured 238 against 142 ms a 100 s flagship case);
  - one by one: each case's `run_case` in this process, summed (a single run's wall and CPU time);
  - the campaign's run on --workers local workers (rows of testbed.campaign.rows.run_cases on
    one started engine, so the cluster's start, the cases' builds for read-back and the summary
    are not in it), batched as shipped and with batch size 1 (each case a task of its own: the
    engine as it was before batches), alternated --repeat times (median);
  - with --command, the same two as whole `testbed campaign` processes (their start, builds
    and summary included); with --before DIR (a checkout of another commit) the second of them
    runs from that tree instead of `--batch-size 1`.
Prints, per configuration, the campaign's wall against the sum of the single runs (1/W at best),
and its cost per case over the bare physics per case (goal <= 1.3), twice: in CPU-equivalent
wall time (wall x workers / cases), and in CPU time (of the workers and of this process, which
holds the local scheduler: what a machine shared with other work still measures); then every case whose verdict or metrics differ between the two
configurations, beyond the lockstep tolerance of tests/test_batch_lockstep.py.
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
import psutil

from testbed.campaign.orchestration import load_cases
from testbed.campaign.engine import Engine
from testbed.campaign.rows import run_case, run_cases
from testbed.plugins import discover
from testbed.run_core.plan import prepare
from testbed.scenario.loading import parse

BATCHED_REL, ABS_FLOOR = 1e-9, 1e-13  # tests/test_batch_lockstep.py


def run_physics_s(cases) -> float:
    """Sum over the cases of the CPU time inside MuJoCo's steps of their own runs [s]: the cases
    stepped as one batch in this process, the physics calls timed (testbed.batch.physics_threads)."""
    from testbed.batch import physics_threads, run_batch

    spent = [0.0]
    each = physics_threads._each

    def timed(calls):
        start = time.process_time()
        each(calls)
        spent[0] += time.process_time() - start

    physics_threads._each = timed
    try:
        run_batch([prepare(parse(case.data, case.source)) for case in cases])
    finally:
        physics_threads._each = each
    return spent[0]


def bare_physics_s(cases) -> float:
    """Sum over the cases of mj_step over each run's steps, in one call, on its built plant [s]."""
    total = 0.0
    for case in cases:
        plan = prepare(parse(case.data, case.source))
        steps = plan.timing.n_ticks * plan.timing.steps_per_tick
        start = time.process_time()
        mujoco.mj_step(plan.plant.model, plan.plant.data, steps)
        total += time.process_time() - start
    return total


def one_by_one_s(cases) -> tuple[float, float]:
    """(wall, CPU) seconds of the cases' run_case one after another in this process (the first one warmed)."""
    run_case(cases[0])
    start, cpu = time.perf_counter(), time.process_time()
    for case in cases:
        run_case(case)
    return time.perf_counter() - start, time.process_time() - cpu


def cpu_s(engine) -> float:
    """CPU seconds (user + system) so far of this process (the local scheduler, the command's
    dispatch) and of every worker process of `engine`."""
    pids = [os.getpid(), *engine.client.run(os.getpid).values()]
    return sum(sum(psutil.Process(pid).cpu_times()[:2]) for pid in pids)


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
        if key == "wall_s" or x == y:
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
    parser.add_argument("--command", action="store_true", help="also time the whole command")
    parser.add_argument("--before", metavar="DIR", help="with --command: a checkout of the commit to compare with")
    args = parser.parse_args()
    discover()
    overrides = [f"sim.duration_s={args.duration:g}", f"sweep.samples={args.cases}"]
    _, _, cases = load_cases(args.scenario, overrides)
    cases = cases[:args.cases]
    if len(cases) != args.cases:
        raise SystemExit(f"{args.scenario} has {len(cases)} cases with these overrides, not {args.cases}")
    one_call = bare_physics_s(cases) / len(cases)
    bare = run_physics_s(cases) / len(cases)
    single, single_cpu = one_by_one_s(cases)
    walls: dict[str, list] = {"batched": [], "batch size 1": []}
    cpus: dict[str, list] = {"batched": [], "batch size 1": []}
    rows = {}
    with Engine(args.workers) as engine:
        run_cases(cases[:args.workers], engine=engine, batch_size=1)  # every worker warmed
        for _ in range(args.repeat):
            for kind, size in (("batched", None), ("batch size 1", 1)):
                start, cpu = time.perf_counter(), cpu_s(engine)
                found = run_cases(cases, engine=engine, batch_size=size)
                walls[kind].append(time.perf_counter() - start)
                cpus[kind].append(cpu_s(engine) - cpu)
                rows[kind] = {str(row["case"]): {k: str(v) for k, v in row.items()} for row in found}
    if args.command:
        second = "before" if args.before else "command, batch size 1"
        walls |= {"command, batched": [], second: []}
        tree = str(Path(args.before).resolve()) if args.before else None
        with tempfile.TemporaryDirectory() as tmp:
            for k in range(args.repeat):
                for kind, extra, where in (("command, batched", [], None),
                                           (second, [] if tree else ["--batch-size", "1"], tree)):
                    wall, found = campaign(args.scenario, overrides, args.workers, Path(tmp) / f"{k}{len(extra)}",
                                           extra, where)
                    walls[kind].append(wall)
                    rows[kind] = found
    print(f"{args.scenario}: {len(cases)} cases of {args.duration:g} s on {args.workers} workers "
          f"(median of {args.repeat}); load average {os.getloadavg()[0]:.1f}")
    print(f"  bare physics   {bare * 1e3:8.1f} ms CPU a case (MuJoCo's steps of the runs themselves; "
          f"{one_call * 1e3:.1f} ms as one mj_step call from the start)")
    print(f"  one by one     {single:8.2f} s wall for the {len(cases)} cases, {single_cpu / len(cases) / bare:.2f}x "
          f"the bare physics a case in CPU")
    for kind, times in walls.items():
        wall = statistics.median(times)
        cpu = f", {statistics.median(cpus[kind]) / len(cases) / bare:.2f}x in CPU" if kind in cpus else ""
        print(f"  {kind:21s} {wall:8.2f} s wall: {wall / single:.3f} of the one-by-one sum; a case "
              f"{wall * args.workers / len(cases) / bare:.2f}x the bare physics (wall x {args.workers} / "
              f"{len(cases)}){cpu}")
    for batched, alone in (("batched", "batch size 1"), ("command, batched", "before" if args.before else
                                                          "command, batch size 1")):
        if batched not in rows:
            continue
        changed = {case: differences(rows[alone][case], rows[batched][case]) for case in rows[alone]}
        changed = {case: found for case, found in changed.items() if found}
        verdicts = sum(rows[alone][c]["passed"] != rows[batched][c]["passed"] for c in rows[alone])
        print(f"  {alone} -> {batched}: {verdicts} verdicts differ, {len(changed)} rows differ beyond "
              f"rel {BATCHED_REL:g} / abs {ABS_FLOOR:g}")
        for case, found in changed.items():
            print(f"    case {case}: {'; '.join(found[:4])}")

if __name__ == "__main__":  # the local cluster's workers start from a fork server
    main()
