"""How far the sampled Lebedev loop is from the continuous one, and what it costs.

    .venv/bin/python bench/bench_lebedev_rates.py [--repeat N] [--holds zero_order,linear]

lebedev_spinup_ideal (Lebedev 1976, section 6; 1000 s) at a grid of law/allocator periods Tc
and sensor/estimator periods Ts = Tc / m, with the estimator's measurement hold `zero_order`
(the older sample held over the interval) or `linear` (interpolated to the newer one). Each
point runs as it would ship: the continuous-time reference `lebedev_continuous` on, the trace
written every law period (so the deviation is taken at every control instant), physics step
dt = Ts. Printed: `max_deviation_from_continuous_deg_s`, whether the scenario's other checks
pass, and the wall and CPU time (fastest of --repeat alternating runs) relative to the
scenario as shipped before issue 16 (Tc = Ts = dt = 0.05 s, zero-order hold, trace every
0.5 s, no reference).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from testbed.runner import run_scenario
from testbed.scenario.loading import load_scenario

LAW_PERIODS = (0.025, 0.05, 0.0625, 0.1)
DIVISIONS = (1, 2, 5, 10)
BEFORE = ("before (as shipped)", ["reference=", "checks={}", "sim.dt_s=0.05", "sim.control_period_s=0.05",
                                  "sim.trace_period_s=0.5",
                                  "pipeline.estimator.measurement_hold=zero_order"])


def point_overrides(law_period: float, division: int, hold: str) -> list[str]:
    """lebedev_spinup_ideal at law period Tc, sensor/estimator period Tc / division (module doc)."""
    sample = law_period / division
    rates = [f"sim.estimator_period_s={sample:.12g}"] if division > 1 else []  # default: one rate
    return ["reference={type: lebedev_continuous}", "checks.max_deviation_from_continuous_deg_s={max: 1e9}",
            f"sim.dt_s={sample:.12g}", f"sim.control_period_s={law_period:.12g}",
            f"sim.trace_period_s={law_period:.12g}", f"pipeline.estimator.measurement_hold={hold}",
            f"pipeline.estimator.max_substep_s={min(0.1, sample):.12g}", *rates]


def run(overrides: list[str]):
    """One run with its trace written: (result, wall s, CPU s of this process)."""
    scenario = load_scenario("lebedev_spinup_ideal", overrides)
    with tempfile.TemporaryDirectory() as tmp:
        wall0, cpu0 = time.perf_counter(), time.process_time()
        result = run_scenario(scenario, Path(tmp) / "rates.rrd")
        wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    if result.status != "ok":
        raise SystemExit(f"{overrides}: {result.status} {result.error}")
    return result, wall, cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--holds", default="zero_order,linear")
    parser.add_argument("--law-periods", default=",".join(map(str, LAW_PERIODS)))
    parser.add_argument("--divisions", default=",".join(map(str, DIVISIONS)))
    args = parser.parse_args()
    points = [BEFORE] + [(f"{hold} Tc {tc:g} Ts {tc / m:g}", point_overrides(tc, m, hold))
                         for hold in args.holds.split(",")
                         for tc in map(float, args.law_periods.split(","))
                         for m in map(int, args.divisions.split(","))]
    walls = {label: float("inf") for label, _ in points}
    cpus = dict(walls)
    results = {}
    for _ in range(args.repeat):  # alternate the points so that load from elsewhere hits all alike
        for label, overrides in points:
            results[label], wall, cpu = run(overrides)
            walls[label], cpus[label] = min(walls[label], wall), min(cpus[label], cpu)
    before = BEFORE[0]
    print(f"lebedev_spinup_ideal, 1000 s simulated, fastest of {args.repeat}; before: "
          f"{walls[before]:.2f} s wall, {cpus[before]:.2f} s CPU")
    print("| point | deviation from continuous [deg/s] | other checks | wall / before | CPU / before |")
    print("|---|---:|:-:|---:|---:|")
    for label, _ in points[1:]:
        result = results[label]
        others = all(c["passed"] for c in result.checks if c["name"] != "max_deviation_from_continuous_deg_s")
        print(f"| {label} | {result.metrics['max_deviation_from_continuous_deg_s']:.4f} | "
              f"{'pass' if others else 'FAIL'} | {walls[label] / walls[before]:.2f} | {cpus[label] / cpus[before]:.2f} |")


if __name__ == "__main__":
    main()
