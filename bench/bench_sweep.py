"""Sweep speed-up: the same sweep run case after case in this process and on the engine's local
Dask cluster of N worker processes.

Prints the wall times and `speedup` = t(in process) / t(N workers) (goal >= 1.7 for N = 2 on
two free cores; the N-worker time includes starting the cluster and importing MuJoCo in each
worker). Also checks that both give the same numbers.

    .venv/bin/python bench/bench_sweep.py [SCENARIO] [--workers N] [--set KEY.PATH=VALUE ...]
"""

import argparse
import math
import time

from testbed.sweep_cli import load_cases
from testbed.sweep_runner import run_case, run_cases


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("scenario", nargs="?", default="akor_sweep")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--set", action="append", default=[], metavar="KEY.PATH=VALUE")
    args = parser.parse_args()
    name, _, cases = load_cases(args.scenario, args.set)
    fields = list(cases[0].values)

    t0 = time.perf_counter()
    serial = [run_case(case) for case in cases]
    serial_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    parallel = run_cases(cases, args.workers)
    parallel_s = time.perf_counter() - t0

    same = all(a.get(k) == v or (isinstance(v, float) and math.isnan(v) and math.isnan(a.get(k)))
               for a, b in zip(parallel, serial) for k, v in b.items() if k != "wall_s")
    print(f"sweep               {name}: {len(cases)} cases over {', '.join(fields)}")
    print(f"passed              {sum(r['passed'] for r in parallel)}/{len(cases)}")
    print(f"serial_wall_s       {serial_s:.2f}   (in this process)")
    print(f"parallel_wall_s     {parallel_s:.2f}   ({args.workers} Dask worker processes, cluster start included)")
    print(f"speedup             {serial_s / parallel_s:.2f}   (goal >= 1.7 with 2 workers)")
    print(f"identical_results   {same}")


if __name__ == "__main__":
    main()
