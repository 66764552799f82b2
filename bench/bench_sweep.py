"""Campaign engine benchmark: the speed-up of 2 Dask workers over 1, and the engine's cost.

For each case length (1 s and 0.2 s of wall time a case, set by cutting the campaign's
simulated time to what this machine runs in that time) the same cases run
  - one after another in this process (no engine): the cases' own time;
  - on the local cluster with 1 worker process, then with 2.
Prints the wall times, `speedup` = t(1 worker) / t(2 workers) (goals: >= 1.8 for 1 s cases,
>= 1.6 for 0.2 s cases on two free cores; both include starting the cluster), the cluster's
start-up, and the engine's overhead per case: (t(1 worker) - start-up - the cases' own run
times in the worker) / cases, in ms. Checks that the three give the same numbers. Then it
interrupts a campaign run as a command (SIGINT to its process group, as Ctrl-C on a terminal)
and prints the time from the signal to the command's exit. The machine's load average is
printed too: other work on the cores lowers the speed-up.

    .venv/bin/python bench/bench_sweep.py [SCENARIO] [--cases-1s N] [--cases-02s N]
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from testbed.campaign.engine import Engine
from testbed.cli.campaign import load_cases
from testbed.campaign.rows import run_case, run_cases


def same_numbers(a: list[dict], b: list[dict]) -> bool:
    def equal(x, y):
        return x == y or (isinstance(x, float) and isinstance(y, float) and math.isnan(x) and math.isnan(y))

    return all(equal(r[k], s.get(k)) for r, s in zip(a, b) for k in r if k != "wall_s")


def sim_seconds_for(scenario: str, wall_s: float) -> float:
    """The simulated time whose run takes `wall_s` here: measured on a 20 s run of case 0."""
    name, data, (case,) = load_cases(scenario, ["sim.duration_s=20"], [0])
    run_case(case)  # warm: imports, caches
    start = time.perf_counter()
    run_case(case)
    per_sim_s = (time.perf_counter() - start) / 20.0
    period = float(data["sim"].get("control_period_s", data["sim"]["dt_s"]))
    return max(period, round(wall_s / per_sim_s / period) * period)


def measure(scenario: str, case_wall_s: float, count: int) -> None:
    sim_s = sim_seconds_for(scenario, case_wall_s)
    name, _, cases = load_cases(scenario, [f"sim.duration_s={sim_s:g}", f"sweep.samples={count}"])
    cases = cases[:count]
    start = time.perf_counter()
    serial = [run_case(case) for case in cases]
    serial_s = time.perf_counter() - start
    timings = {}
    for workers in (1, 2):
        start = time.perf_counter()
        with Engine(workers) as engine:
            started = time.perf_counter()
            rows = run_cases(cases, engine=engine)
            ran = time.perf_counter()
        timings[workers] = (ran - start, started - start, ran - started, rows)
    (t1, up1, run1, rows1), (t2, up2, run2, rows2) = timings[1], timings[2]
    own = sum(row["wall_s"] for row in rows1)
    print(f"--- {count} cases of {name}, sim.duration_s = {sim_s:g} ({serial_s / count:.3f} s a case in this process)")
    print(f"in_process_wall_s   {serial_s:8.2f}")
    print(f"1_worker_wall_s     {t1:8.2f}   (cluster start {up1:.2f} s, cases {run1:.2f} s)")
    print(f"2_workers_wall_s    {t2:8.2f}   (cluster start {up2:.2f} s, cases {run2:.2f} s)")
    print(f"speedup             {t1 / t2:8.2f}   (2 workers over 1, start included; goal >= "
          f"{1.8 if case_wall_s >= 1 else 1.6}); without the start: {run1 / run2:.2f}")
    print(f"overhead_ms_a_case  {1000 * (run1 - own) / count:8.1f}   (1 worker: wall - the cases' own run times)")
    print(f"identical_results   {same_numbers(serial, rows1) and same_numbers(serial, rows2)}")


def interrupt_latency(scenario: str) -> None:
    """Seconds from SIGINT to the exit of `testbed campaign` with finished rows on disk."""
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "out"
        command = subprocess.Popen([sys.executable, "-m", "testbed", "campaign", scenario, "--workers", "2",
                                    "--out", str(out), "--set", "sim.duration_s=50"],
                                   stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                                   start_new_session=True)
        table = out / f"{scenario}.csv"
        while not table.exists() or len(table.read_text().splitlines()) < 1 + 4:
            if command.poll() is not None:
                raise SystemExit(f"the campaign ended early: {command.stderr.read()}")
            time.sleep(0.02)
        os.killpg(command.pid, signal.SIGINT)
        sent = time.perf_counter()
        command.wait()
        latency = time.perf_counter() - sent
        rows = len(table.read_text().splitlines()) - 1
    print(f"--- Ctrl-C on `testbed campaign {scenario}` (2 workers) after 4 rows")
    print(f"ctrl_c_to_exit_s    {latency:8.2f}   (goal <= 2; exit status {command.returncode}, {rows} rows kept)")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("scenario", nargs="?", default="lebedev_spinup_campaign")
    parser.add_argument("--cases-1s", type=int, default=40)
    parser.add_argument("--cases-02s", type=int, default=100)
    args = parser.parse_args()
    print(f"load average at start {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    measure(args.scenario, 1.0, args.cases_1s)
    measure(args.scenario, 0.2, args.cases_02s)
    interrupt_latency(args.scenario)
    print(f"load average at end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
