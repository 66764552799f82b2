"""What the orbit and the environment add to the per-tick cost of the flagship's loop.

Runs reorient_minimax (the 4-CMG slew with min-max steering) as shipped and again with an
orbit and every environment torque on (gravity gradient, drag, solar pressure, residual
dipole, magnetometer and magnetorquers with the desaturation law, updated every
environment.update_period_s), alternating, the fastest CPU time of each kept. Prints the CPU
time per control tick of both and their ratio (goal: the environment adds at most 20 %).

    .venv/bin/python bench/bench_environment.py [--duration S] [--repeat N] [--update S]
"""

import argparse
import time

from testbed.runner import run_scenario
from testbed.scenario.loading import load_scenario

ENVIRONMENT = ("{drag: {}, solar_pressure: {}, magnetic_field: {residual_dipole_am2: [0.5, 0.5, 1]},"
               " magnetometer: {noise_t: 1.0e-7}, magnetorquers: {}, update_period_s: %g}")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--duration", type=float, default=60.0, help="simulated seconds")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--update", type=float, default=1.0, help="environment.update_period_s")
    args = parser.parse_args()
    base = ["checks={}", f"sim.duration_s={args.duration}"]
    cases = {"bare": load_scenario("reorient_minimax", base),
             "in orbit": load_scenario("reorient_minimax", base + ["orbit={altitude_km: 450}",
                                                                   "environment=" + ENVIRONMENT % args.update])}
    best = {name: float("inf") for name in cases}
    for _ in range(args.repeat):
        for name, scenario in cases.items():
            start = time.process_time()
            result = run_scenario(scenario, None)
            best[name] = min(best[name], time.process_time() - start)
            assert result.status == "ok", result.error
    ticks = round(args.duration / cases["bare"].sim.control_period_s)
    for name, cpu in best.items():
        print(f"{name:>9}: {1e6 * cpu / ticks:8.1f} us CPU per control tick")
    print(f"environment_over_bare: {best['in orbit'] / best['bare']:.3f} (goal <= 1.2)")


if __name__ == "__main__":
    main()
