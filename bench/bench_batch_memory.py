"""Memory per world of a batch of worlds stepped in lockstep (testbed.batch), against the bound
the code states.

For each N a fresh process loads N copies of the scenario (the flagship by default, shortened,
each world's initial rate a little different), reads its resident set size (RSS) after the
imports, prepares the N plans, runs them as one `Batch` to the end (no `.rrd`) and reads RSS
again, and its peak (getrusage ru_maxrss). A second fresh process does the same under
tracemalloc, for the share that is Python's and NumPy's (MuJoCo's C allocations are not
traced). Prints a row per N and the least-squares slope over N: the memory one more world
costs. Then the bound from the code, for one world:

- MuJoCo: `mj_sizeModel` + the MjData buffer (`nbuffer`) + its arena (`narena`: allocated;
  only the pages the arena's stack touches are resident, `maxuse_arena`);
- the trace: the batch recorder's column, `CHUNK_ROWS` x the sample's width x 8 bytes, and in
  the world's own recorder a buffer of `CHUNK_ROWS` rows for each truth signal of its final
  sample, and the kept times (a flush copies one world's column at a time: once a batch);
- the kept histories (`RunPlan.kept_signals`): the kept width x 8 bytes a trace sample, i.e.
  8 x width / trace_period_s bytes a simulated second (the buffer doubles: at most twice that).

Linux only (RSS read from /proc/self/statm).

    .venv/bin/python bench/bench_batch_memory.py [SCENARIO] [--worlds 1 8 32 64] [--duration 10]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

import numpy as np

CHILD = """
import json, os, resource, sys, time, tracemalloc
import testbed
from testbed.batch import Batch
from testbed.run_core.plan import prepare

def rss_mb():
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20

name, duration, n, traced = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4] == "1"
scenarios = [testbed.load(name, [f"sim.duration_s={duration}", f"initial.omega_deg_s=[{0.25 + 0.001 * i}, -0.25, 0]"])
             for i in range(n)]
rss0 = rss_mb()
if traced:
    tracemalloc.start()
t0 = time.perf_counter()
plans = [prepare(scenario) for scenario in scenarios]
rss_plans = rss_mb()
python_plans = tracemalloc.get_traced_memory()[0] / 2**20 if traced else None
if traced:
    tracemalloc.reset_peak()
with Batch(plans) as batch:
    batch.advance(batch.timing.n_ticks)
    rss_run = rss_mb()  # every world's buffers still held
    python_run = tracemalloc.get_traced_memory()[1] / 2**20 if traced else None
    results = batch.finish()
print(json.dumps({"rss0_mb": rss0, "plans_mb": rss_plans - rss0, "run_mb": rss_run - rss0,
                  "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024 - rss0,
                  "python_plans_mb": python_plans, "python_peak_mb": python_run,
                  "wall_s": time.perf_counter() - t0,
                  "statuses": sorted({result.status for result in results})}))
"""


def child(name: str, duration: float, n: int, traced: bool) -> dict:
    out = subprocess.run([sys.executable, "-c", CHILD, name, f"{duration:g}", str(n), "1" if traced else "0"],
                         check=True, capture_output=True, text=True, timeout=1800)
    return json.loads(out.stdout.strip().splitlines()[-1])


def slope(worlds: list[int], values: list[float]) -> tuple[float, float]:
    """(per world, at zero worlds) of the least-squares line through (worlds, values)."""
    per_world, offset = np.polyfit(np.array(worlds, dtype=float), np.array(values, dtype=float), 1)
    return per_world, offset


def bound(name: str, duration: float) -> dict:
    """One world's memory as the code lays it out [bytes] (see the module's docstring)."""
    import mujoco

    import testbed
    from testbed.recording.recorder import CHUNK_ROWS
    from testbed.run_core.plan import prepare

    plan = prepare(testbed.load(name, [f"sim.duration_s={duration:g}"]))
    plant, pipeline, timing = plan.plant, plan.pipeline, plan.timing
    pipeline.tick(0.0, plant)  # a sample as the loop takes it (testbed.run_core.loop.run_ticks)
    sample = pipeline.signals()
    sample["truth"] = plant.truth()
    mujoco.mj_step(plant.model, plant.data, timing.steps_per_tick)  # the arena's stack as a step uses it
    widths = {f"{group}/{key}": int(np.size(value)) for group, signals in sample.items() for key, value in signals.items()}
    width = sum(widths.values())
    kept = sum(widths.get(key, 0) for key in (plan.kept_signals or ()))
    truth = sum(value for key, value in widths.items() if key.startswith("truth/"))
    data = plant.data
    return {"model": mujoco.mj_sizeModel(plant.model), "data_buffer": data.nbuffer, "arena": data.narena,
            "arena_used": data.maxuse_arena, "width": width, "trace_column": CHUNK_ROWS * width * 8,
            "chunk_rows": CHUNK_ROWS, "truth_width": truth, "kept_width": kept, "kept_per_s": 8 * kept / timing.trace_period_s}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("scenario", nargs="?", default="lebedev_spinup_cmg")
    parser.add_argument("--worlds", type=int, nargs="+", default=[1, 8, 32, 64])
    parser.add_argument("--duration", type=float, default=10.0, help="simulated seconds of each world")
    parser.add_argument("--no-tracemalloc", action="store_true", help="RSS only (half the time)")
    args = parser.parse_args()

    print(f"{args.scenario}, {args.duration:g} s simulated, MB over the process after its imports")
    print(f"{'N':>4s} {'plans_mb':>9s} {'run_mb':>8s} {'peak_mb':>8s} {'py_plans':>9s} {'py_peak':>8s} "
          f"{'wall_s':>7s}  statuses")
    rows = []
    for n in args.worlds:
        row = child(args.scenario, args.duration, n, False)
        traced = {} if args.no_tracemalloc else child(args.scenario, args.duration, n, True)
        row["python_plans_mb"], row["python_peak_mb"] = traced.get("python_plans_mb"), traced.get("python_peak_mb")
        rows.append(row)
        python = (f"{row['python_plans_mb']:9.2f} {row['python_peak_mb']:8.2f}" if traced else f"{'-':>9s} {'-':>8s}")
        print(f"{n:4d} {row['plans_mb']:9.2f} {row['run_mb']:8.2f} {row['peak_mb']:8.2f} {python} "
              f"{row['wall_s']:7.2f}  {','.join(row['statuses'])}", flush=True)

    if len(rows) > 1:
        print("per world (least-squares slope over N; at N = 0 in brackets):")
        for key, what in (("plans_mb", "plans (plant, MuJoCo, stages)"), ("run_mb", "after the run, all held"),
                          ("peak_mb", "peak RSS"), ("python_plans_mb", "Python and NumPy, plans"),
                          ("python_peak_mb", "Python and NumPy, peak")):
            if rows[0][key] is None:
                continue
            per_world, offset = slope(args.worlds, [row[key] for row in rows])
            print(f"  {what:32s} {per_world * 1024:8.0f} kB a world   ({offset:6.2f} MB)")

    b = bound(args.scenario, args.duration)
    mujoco_kb = (b["model"] + b["data_buffer"] + b["arena_used"]) / 1024
    print("the bound from the code, one world:")
    print(f"  MuJoCo: model {b['model'] / 1024:.1f} kB + data buffer {b['data_buffer'] / 1024:.1f} kB + arena "
          f"used {b['arena_used'] / 1024:.1f} kB = {mujoco_kb:.1f} kB resident "
          f"(arena allocated {b['arena'] / 2**20:.1f} MB, untouched pages not resident)")
    rows_kb = b["chunk_rows"] * 8 / 1024
    held = b["trace_column"] + (b["truth_width"] + 1) * b["chunk_rows"] * 8
    print(f"  trace: {b['chunk_rows']} rows x {b['width']} floats x 8 B = {b['trace_column'] / 1024:.0f} kB "
          f"in the batch recorder; in the world's own recorder its final sample's truth, {b['truth_width']} "
          f"floats, in a buffer of {b['chunk_rows']} rows ({b['truth_width'] * rows_kb:.0f} kB) and the kept "
          f"times ({rows_kb:.0f} kB): {held / 1024:.0f} kB a world; a flush copies one world's column at a time "
          f"(at most {b['trace_column'] / 1024:.0f} kB for the whole batch)")
    print(f"  kept histories: {b['kept_width']} floats a sample = {b['kept_per_s'] / 1024:.2f} kB a simulated second "
          f"(at most twice that, the buffer doubling)")


if __name__ == "__main__":
    main()
