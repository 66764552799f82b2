"""The step API's cost per control period against the plain loop's (issue 28; goal <= 2x).

The same scenario, in this process, four ways: bare mj_step over the run's physics steps;
`testbed.run` (the runner's loop run to the end at once); `testbed.Simulation.step()` once a
control period; and `step(command)` with the law's torque given each period (the path of the
Gymnasium environments' torque action). Each way's Python cost per control period is its
CPU time minus bare mj_step's, over the periods (no trace file, the reference off). Prints
each, and `step_over_loop` = step()'s cost over the loop's (goal <= 2).

    .venv/bin/python bench/bench_stepping.py [SCENARIO] [--duration S] [--repeat N]
"""

import argparse
import time

import mujoco
import numpy as np

import testbed
from testbed.runner import one_blas_thread, prepare


def stepped(scenario, overrides, command=None) -> None:
    sim = testbed.Simulation(scenario, overrides, keep_trace=False)
    step = sim.step
    if command is None:
        while sim.running:
            step()
    else:
        while sim.running:
            step(command)
    sim.close()


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("scenario", nargs="?", default="reorient_minimax")
    parser.add_argument("--duration", type=float, default=20.0, help="simulated seconds")
    parser.add_argument("--repeat", type=int, default=3, help="alternating repetitions; the fastest of each counts")
    args = parser.parse_args()
    overrides = ["reference=", "checks={}", f"sim.duration_s={args.duration}"]
    scenario = testbed.load(args.scenario, overrides)
    steps = round(scenario.sim.duration_s / scenario.sim.dt_s)
    ticks = round(scenario.sim.duration_s / scenario.sim.control_period_s)
    command = {"law": {"torque": np.zeros(3)}}
    ways = {"bare": None, "loop": None, "step": None, "step_command": None}
    cpu = dict.fromkeys(ways, float("inf"))
    for _ in range(args.repeat):  # alternated, so that load from other processes hits all alike
        with one_blas_thread():
            plant, _, _ = prepare(scenario)
        c0 = time.process_time()
        mujoco.mj_step(plant.model, plant.data, nstep=steps)
        cpu["bare"] = min(cpu["bare"], time.process_time() - c0)
        for way, run in (("loop", lambda: testbed.run(scenario, keep_trace=False)),
                         ("step", lambda: stepped(args.scenario, overrides)),
                         ("step_command", lambda: stepped(args.scenario, overrides, command))):
            c0 = time.process_time()
            run()
            cpu[way] = min(cpu[way], time.process_time() - c0)
    per_period = {way: (cpu[way] - cpu["bare"]) / ticks * 1e6 for way in ("loop", "step", "step_command")}
    print(f"scenario                    {scenario.name}: {args.duration:g} s, {ticks} control periods, {steps} physics steps")
    print(f"bare_mj_step_cpu_s          {cpu['bare']:.3f}")
    for way, cost in per_period.items():
        print(f"{way + '_us_per_period':<28}{cost:.1f}   (CPU {cpu[way]:.3f} s)")
    print(f"step_over_loop              {per_period['step'] / per_period['loop']:.2f}   (goal <= 2)")
    print(f"command_over_loop           {per_period['step_command'] / per_period['loop']:.2f}")


if __name__ == "__main__":
    main()
