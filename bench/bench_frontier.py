"""Accuracy against speed for cmg_open_loop: the physics step and the gimbal servo model.

    .venv/bin/python bench/bench_frontier.py [--repeat N] [--duration S]   # the frontier table
    .venv/bin/python bench/bench_frontier.py --sources                   # where the drift comes from

The frontier: for dt in 0.001 ... 0.02 s and each servo model, cmg_open_loop run as a user
runs it (trace written, the analytic reference off: it is an oracle, not part of the run), with
its tracking error `gimbal_rate_error_rel`, its momentum drift `momentum_drift_rel` and the
simulated seconds per wall second (the fastest of --repeat alternating runs). The control
period is 0.01 s (dt when dt is longer), the trace period 0.1 s; intvelocity at the stiffest
servo RK4 accepts (w_n = min(316, 0.69 / dt) rad/s), feedforward at w_n = 5 rad/s. The
first row is the scenario as shipped before the feedforward servo (dt 0.002 s, intvelocity
316 rad/s, trace every control tick), the baseline of the `wall / before` column.

--sources runs the ablations that gimbal_servo.py's docstring cites: the drift accumulated
by t = 0.1 s and by the end of the run, with one thing changed at a time.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from testbed.runner import run_scenario
from testbed.scenario.loading import load_scenario

STEPS = (0.001, 0.002, 0.005, 0.01, 0.02)
FEEDFORWARD_W_N = 5.0
BEFORE = ("before (as shipped)", ["sim.dt_s=0.002", "model.servo_model=intvelocity",
                                  "model.servo_natural_frequency_rad_s=316", "sim.control_period_s=0.01",
                                  "sim.trace_period_s=0.01", "model.rotor_speed_time_constant_s=0.02"])


def step_overrides(dt: float, servo: str) -> list[str]:
    """cmg_open_loop at step dt with `servo` (module docstring)."""
    w_n = min(316.0, 0.69 / dt) if servo == "intvelocity" else FEEDFORWARD_W_N
    control = max(0.01, dt)
    return [f"sim.dt_s={dt}", f"sim.control_period_s={control}", "sim.trace_period_s=0.1",
            f"model.servo_model={servo}", f"model.servo_natural_frequency_rad_s={w_n:g}",
            f"model.rotor_speed_time_constant_s={max(0.02, 2 * dt):g}"]


def run(overrides: list[str], duration: float | None, keep: bool = False):
    """One cmg_open_loop run with its trace written: (result, wall seconds, CPU seconds of
    this process; the second is less sensitive to other processes on the machine)."""
    extra = ["reference=", "checks={}"] + ([f"sim.duration_s={duration}"] if duration else [])
    scenario = load_scenario("cmg_open_loop", extra + overrides)
    with tempfile.TemporaryDirectory() as tmp:
        wall0, cpu0 = time.perf_counter(), time.process_time()
        result = run_scenario(scenario, Path(tmp) / "frontier.rrd", keep_data=keep)
        wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    if result.status != "ok":
        raise SystemExit(f"{overrides}: {result.status} {result.error}")
    return result, wall, cpu


def frontier(repeat: int, duration: float | None) -> None:
    points = [BEFORE] + [(f"{servo} dt {dt:g}", step_overrides(dt, servo))
                         for dt in STEPS for servo in ("intvelocity", "feedforward")]
    walls = {label: float("inf") for label, _ in points}
    cpus = dict(walls)
    results = {}
    for _ in range(repeat):  # alternate the points so that load from elsewhere hits all alike
        for label, overrides in points:
            results[label], wall, cpu = run(overrides, duration)
            walls[label], cpus[label] = min(walls[label], wall), min(cpus[label], cpu)
    simulated = results[BEFORE[0]].sim_s
    before = BEFORE[0]
    print(f"cmg_open_loop, {simulated:g} s simulated, fastest of {repeat}")
    print("| point | tracking error | momentum drift | sim s / wall s | wall / before | CPU / before |")
    print("|---|---:|---:|---:|---:|---:|")
    for label, _ in points:
        m = results[label].metrics
        print(f"| {label} | {m['gimbal_rate_error_rel']:.2e} | {m['momentum_drift_rel']:.1e} | "
              f"{simulated / walls[label]:.0f} | {walls[label] / walls[before]:.2f} | {cpus[label] / cpus[before]:.2f} |")


SOURCES = [
    ("intvelocity dt 0.002 w_n 316", ["sim.dt_s=0.002", "model.servo_natural_frequency_rad_s=316"]),
    ("intvelocity dt 0.01 w_n 69", ["model.servo_natural_frequency_rad_s=69"]),
    ("  dt 0.005", ["sim.dt_s=0.005", "model.servo_natural_frequency_rad_s=69"]),
    ("  gimbal inertia (0.03, 0.04, 0.04)", ["model.servo_natural_frequency_rad_s=69",
                                             "model.gimbal_inertia_kg_m2=[0.03, 0.04, 0.04]"]),
    ("  12000 rpm, same gimbal-axis inertia", ["model.servo_natural_frequency_rad_s=69", "model.rotor_speed_rpm=12000",
                                               "model.gimbal_inertia_kg_m2=[0.053873, 0.04, 0.04]"]),
    ("  rotor loop tau 0.2 s", ["model.servo_natural_frequency_rad_s=69", "model.rotor_speed_time_constant_s=0.2"]),
    ("feedforward dt 0.01 w_n 5", ["model.servo_model=feedforward"]),
    ("  w_n 1", ["model.servo_model=feedforward", "model.servo_natural_frequency_rad_s=1"]),
    ("  w_n 30", ["model.servo_model=feedforward", "model.servo_natural_frequency_rad_s=30"]),
    ("  dt 0.005", ["model.servo_model=feedforward", "sim.dt_s=0.005"]),
    ("  command starts at 0 (phases 0)", ["model.servo_model=feedforward", "pipeline.allocator.phase_deg=[0, 0, 0, 0]"]),
    ("  phases 0, dt 0.005", ["model.servo_model=feedforward", "pipeline.allocator.phase_deg=[0, 0, 0, 0]",
                              "sim.dt_s=0.005"]),
    ("  phases 0, amplitude x2", ["model.servo_model=feedforward", "pipeline.allocator.phase_deg=[0, 0, 0, 0]",
                                  "pipeline.allocator.amplitude_deg_s=[6, 4, 8, 5]"]),
    ("  phases 0, gimbal inertia (0.3, 0.2, 0.2)", ["model.servo_model=feedforward",
                                                     "pipeline.allocator.phase_deg=[0, 0, 0, 0]",
                                                     "model.gimbal_inertia_kg_m2=[0.3, 0.2, 0.2]"]),
    ("  phases 0, 12000 rpm, same gimbal-axis inertia", ["model.servo_model=feedforward",
                                                          "pipeline.allocator.phase_deg=[0, 0, 0, 0]",
                                                          "model.rotor_speed_rpm=12000",
                                                          "model.gimbal_inertia_kg_m2=[0.053873, 0.04, 0.04]"]),
    ("  gimbals still", ["model.servo_model=feedforward", "pipeline.allocator.amplitude_deg_s=[0, 0, 0, 0]"]),
]


def sources(duration: float | None) -> None:
    base = ["sim.dt_s=0.01", "sim.control_period_s=0.01", "sim.trace_period_s=0.1",
            f"model.servo_natural_frequency_rad_s={FEEDFORWARD_W_N:g}", "model.servo_model=intvelocity"]
    print("drift = |L(t) - L(0)| / stored rotor momentum; tracking = gimbal_rate_error_rel")
    print("| case | drift by 0.1 s | drift by the end | tracking |")
    print("|---|---:|---:|---:|")
    for label, overrides in SOURCES:
        result, _, _ = run(base + overrides, duration, keep=True)
        t, momentum = result.trace["truth/angular_momentum_world"]
        drift = np.linalg.norm(momentum - momentum[0], axis=1) / result.data.momentum_scale
        commanded = np.max(np.abs(result.trace["truth/gimbal_rate_command"][1])) > 0
        tracking = f"{result.metrics['gimbal_rate_error_rel']:.2e}" if commanded else "-"
        print(f"| {label} | {np.max(drift[t <= 0.1 + 1e-9]):.2e} | {np.max(drift):.2e} | {tracking} |")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--sources", action="store_true", help="the drift ablations instead of the frontier")
    parser.add_argument("--repeat", type=int, default=3, help="alternating repetitions; the fastest of each counts")
    parser.add_argument("--duration", type=float, default=None, help="simulated seconds (default: the scenario's)")
    args = parser.parse_args()
    if args.sources:
        sources(args.duration)
    else:
        frontier(args.repeat, args.duration)


if __name__ == "__main__":
    main()
