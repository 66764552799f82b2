"""Peak memory against simulated duration, and the share of wall time the trace costs.

Each run is a fresh process (`run_scenario` as `testbed run` calls it, the `.rrd` written to a
temporary folder), so its peak resident set size (getrusage ru_maxrss) is its own. Prints one
row per duration: peak RSS [MB], wall time, and the ratio of each peak to the shortest run's
(goal: the longest within 1.2x of the shortest). Then the logging share: the same scenario at
`--share-duration` with the `.rrd` written (and, with `--view-sink`, streamed to an in-process
gRPC server too) against no trace file at all, (cpu_with - cpu_without) / cpu_with (goal <= 5 %),
the median of `--repeat` alternating runs each. CPU time of the process (all its threads,
Rerun's encoder included) rather than wall time: on a shared machine other processes change
the wall time by more than the trace costs.

    .venv/bin/python bench/bench_memory.py [SCENARIO] [--durations 30 3000 30000] [--no-reference]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

CHILD = """
import json, resource, sys, tempfile, time
from pathlib import Path
from testbed.runner import run_scenario
from testbed.scenario.loading import load_scenario
name, overrides, write, connect = sys.argv[1], json.loads(sys.argv[2]), sys.argv[3] == "1", sys.argv[4]
scenario = load_scenario(name, overrides)
with tempfile.TemporaryDirectory() as tmp:
    live = None
    if connect == "server":  # a viewer-less gRPC server in this process, reached as `--connect URL` reaches a viewer
        import rerun as rr
        server = rr.RecordingStream("bench-sink")  # kept: the server lives as long as its stream
        url = server.serve_grpc(grpc_port=9897, server_memory_limit="64MB")
        from testbed.recording.live_view import ViewerStream
        live = ViewerStream(url)
    t0, c0 = time.perf_counter(), time.process_time()
    result = run_scenario(scenario, Path(tmp) / "run.rrd" if write else None, live=live)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    size = (Path(tmp) / "run.rrd").stat().st_size if write else 0
print(json.dumps({"status": result.status, "wall_s": wall, "cpu_s": cpu, "rrd_mb": size / 1e6,
                  "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "metrics": result.metrics}))
"""


def child(name: str, overrides: list[str], write: bool = True, connect: str = "") -> dict:
    out = subprocess.run([sys.executable, "-c", CHILD, name, json.dumps(overrides), "1" if write else "0", connect],
                         check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("scenario", nargs="?", default="cmg_open_loop")
    parser.add_argument("--durations", type=float, nargs="+", default=[30.0, 3000.0, 30000.0])
    parser.add_argument("--no-reference", action="store_true",
                        help="switch the analytic reference off (it dominates the wall time of long runs)")
    parser.add_argument("--share-duration", type=float, default=600.0)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--view-sink", action="store_true", help="also measure the share with a live gRPC sink")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a scenario override")
    args = parser.parse_args()
    base = list(args.set) + (["reference=", "checks={}"] if args.no_reference else [])

    print(f"scenario {args.scenario}{' (no reference)' if args.no_reference else ''}")
    print(f"{'simulated_s':>12s} {'peak_rss_mb':>12s} {'over_first':>10s} {'wall_s':>8s} {'rrd_mb':>8s}  status")
    first = None
    for duration in args.durations:
        row = child(args.scenario, base + [f"sim.duration_s={duration:g}"])
        first = first or row["peak_rss_mb"]
        print(f"{duration:12g} {row['peak_rss_mb']:12.1f} {row['peak_rss_mb'] / first:10.3f} "
              f"{row['wall_s']:8.2f} {row['rrd_mb']:8.1f}  {row['status']}", flush=True)

    share = base + [f"sim.duration_s={args.share_duration:g}", "reference=", "checks={}"]
    kinds = {"no trace file": (False, ""), ".rrd written": (True, "")}
    if args.view_sink:
        kinds[".rrd + live gRPC sink"] = (True, "server")
    runs = {kind: [] for kind in kinds}
    for _ in range(args.repeat):  # alternate, so that load from other processes hits all alike
        for kind, (write, connect) in kinds.items():
            runs[kind].append(child(args.scenario, share, write, connect))
    if not args.repeat:
        return
    cpu = {kind: statistics.median(r["cpu_s"] for r in rows) for kind, rows in runs.items()}
    wall = {kind: statistics.median(r["wall_s"] for r in rows) for kind, rows in runs.items()}
    print(f"logging share at {args.share_duration:g} s simulated (no reference; median of {args.repeat}):")
    for kind in kinds:
        print(f"  {kind:24s} cpu {cpu[kind]:7.3f} s  wall {wall[kind]:7.3f} s   "
              f"logging_share {(cpu[kind] - cpu['no trace file']) / cpu[kind]:6.1%}  (goal <= 5 %)")


if __name__ == "__main__":
    main()
