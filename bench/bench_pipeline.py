"""Pipeline overhead: cmg_open_loop through the whole pipeline with logging vs bare MuJoCo.

Both run the same compiled model for the same simulated time in this process; the analytic
reference is switched off (it is an oracle, not part of a user's run). Prints
`pipeline_over_bare` (goal <= 1.3), simulated seconds per wall second and the cost per
control tick outside mj_step (goal <= 5 us): the run's wall time (stages, servo, trace
samples, metrics, the .rrd written) minus bare mj_step's, over the number of ticks.

    .venv/bin/python bench/bench_pipeline.py [SCENARIO] [--duration S] [--set KEY=VALUE ...]
"""

import argparse
import tempfile
import time
from pathlib import Path

import mujoco

from testbed.runner import one_blas_thread
from testbed.runner import prepare, run_scenario
from testbed.scenario.loading import load_scenario


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("scenario", nargs="?", default="cmg_open_loop")
    parser.add_argument("--duration", type=float, default=None, help="simulated seconds (default: the scenario's)")
    parser.add_argument("--repeat", type=int, default=3, help="alternating repetitions; the fastest of each counts")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a scenario override")
    args = parser.parse_args()
    overrides = ["reference=", "checks={}", *args.set]
    if args.duration:
        overrides.append(f"sim.duration_s={args.duration}")
    scenario = load_scenario(args.scenario, overrides)
    steps = round(scenario.sim.duration_s / scenario.sim.dt_s)
    ticks = round(scenario.sim.duration_s / scenario.sim.control_period_s)
    pipeline_s = bare_s = pipeline_cpu = bare_cpu = float("inf")
    # Alternate the two so that load from other processes hits both alike; keep the fastest.
    # CPU time (of this process) is printed beside: other processes barely change it.
    for _ in range(args.repeat):
        with tempfile.TemporaryDirectory() as tmp:
            t0, c0 = time.perf_counter(), time.process_time()
            result = run_scenario(scenario, Path(tmp) / "bench.rrd")
            pipeline_s, pipeline_cpu = min(pipeline_s, time.perf_counter() - t0), min(pipeline_cpu, time.process_time() - c0)
        with one_blas_thread():  # as in run_scenario: no BLAS threads spinning into the bare run's CPU time
            plant, _, _ = prepare(scenario)
        t0, c0 = time.perf_counter(), time.process_time()
        mujoco.mj_step(plant.model, plant.data, nstep=steps)
        bare_s, bare_cpu = min(bare_s, time.perf_counter() - t0), min(bare_cpu, time.process_time() - c0)

    print(f"scenario            {scenario.name} ({result.status})")
    print(f"simulated_s         {scenario.sim.duration_s:g}  ({steps} physics steps, dt = {scenario.sim.dt_s:g} s)")
    print(f"pipeline_wall_s     {pipeline_s:.3f}   (run + trace written)")
    print(f"bare_mj_step_wall_s {bare_s:.3f}")
    print(f"pipeline_over_bare  {pipeline_s / bare_s:.3f}   (goal <= 1.3; CPU time: {pipeline_cpu / bare_cpu:.3f})")
    print(f"tick_overhead_us    {(pipeline_s - bare_s) / ticks * 1e6:.2f}   ({ticks} control ticks; goal <= 5; "
          f"CPU time: {(pipeline_cpu - bare_cpu) / ticks * 1e6:.2f})")
    print(f"sim_s_per_wall_s    {scenario.sim.duration_s / pipeline_s:.1f}")


if __name__ == "__main__":
    main()
