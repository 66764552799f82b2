"""Each shipped CMG scenario at the accuracy frontier: the dt it ships at, the next dt tried, what broke there.

    .venv/bin/python bench/bench_cmg_frontier.py [NAME ...]     # about 2-4 minutes for all

The ladder of physics steps (each a whole divisor of the 0.05 s control period) and the gimbal
servo each step runs with (docs/theory/gimbal-servo.md, "Choosing dt"; the intvelocity servo at
the stiffest w_n RK4 accepts, 0.69 / dt, the feedforward one soft):

    0.002 s   intvelocity w_n 316 rad/s
    0.0025 s  feedforward w_n 0.1 rad/s, or intvelocity w_n 276 rad/s
    0.005 s   feedforward w_n 0.1 rad/s
    0.01 s    feedforward w_n 0.1 or 0.03 rad/s
    0.025 s   feedforward w_n 0.1 rad/s, rotor loop tau 0.05 s (RK4 needs dt / tau <= 0.5)

The feedforward servo's PD is soft (its held motor torque does the tracking): the drift falls
with w_n, at 0.005 s on the flagship 1.6e-9 at 0.3 rad/s and 5.6e-10 at 0.1.

A step passes when the run passes its own checks with their shipped bounds, the accuracy guard
(testbed/accuracy/: drift, servo tracking, step angle) and equal accuracy: momentum_drift_rel
<= 1e-9 where the metric applies. For each scenario the script runs the shipped configuration and
the next step of the ladder above the shipped dt (every variant of it), and prints what broke
there. The campaigns run their base case (no dispersion).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from testbed.runner import run_scenario
from testbed.scenario.loading import load_scenario

SCENARIOS = ("lebedev_spinup_cmg", "lebedev_spinup_cmg_momentum", "lebedev_spinup_campaign", "reorient_near_singular",
             "reorient_near_singular_avoid", "reorient_gimbal_limits", "reorient_campaign", "cmg_open_loop",
             "reorient_minimax", "reorient_minimax_avoid", "reorient_pinv")
DRIFT_MAX = 1e-9


def feedforward(w_n: float, tau: float = 0.02) -> list[str]:
    return ["model.servo_model=feedforward", f"model.servo_natural_frequency_rad_s={w_n:g}",
            f"model.rotor_speed_time_constant_s={tau:g}"]


def intvelocity(w_n: float) -> list[str]:
    return ["model.servo_model=intvelocity", f"model.servo_natural_frequency_rad_s={w_n:g}",
            "model.rotor_speed_time_constant_s=0.02"]


LADDER = [(0.002, [intvelocity(316)]),
          (0.0025, [feedforward(0.1), intvelocity(276)]),
          (0.005, [feedforward(0.1)]),
          (0.01, [feedforward(0.1), feedforward(0.03)]),
          (0.025, [feedforward(0.1, 0.05)])]


def broke(name: str, overrides: list[str]) -> tuple[str, float]:
    """What fails in `name` run with `overrides` ('' if nothing), and the wall seconds."""
    try:
        scenario = load_scenario(name, overrides)
    except Exception as exc:  # a refused step (the accuracy guard at load, a servo bound)
        return f"refused: {exc}", 0.0
    wall0 = time.perf_counter()
    result = run_scenario(scenario, None)
    wall = time.perf_counter() - wall0
    if result.status != "ok":
        return f"{result.status}: {result.error}", wall
    failed = [f"{c['name']} {c['value']:.3g} ({c['limit']})" for c in result.checks if not c["passed"]]
    drift = result.metrics.get("momentum_drift_rel")
    if drift is not None and drift > DRIFT_MAX:
        failed.append(f"momentum_drift_rel {drift:.3g} (equal accuracy <= {DRIFT_MAX:g})")
    return "; ".join(failed), wall


def is_campaign(name: str) -> bool:
    """A scenario with a sweep: block (its cases, not its base case, judge a step)."""
    return "\nsweep:" in Path(load_scenario(name).source).read_text()


def frontier(name: str) -> tuple:
    shipped = load_scenario(name).sim.dt_s
    ok, wall = broke(name, [])
    rungs = [(dt, variants) for dt, variants in LADDER if dt > shipped + 1e-12]
    if not rungs:
        return shipped, ok or "passes", wall, None, "top of the ladder"
    dt, variants = rungs[0]
    reasons = []
    for variant in variants:
        control = max(dt, load_scenario(name).sim.control_period_s)
        why, _ = broke(name, [f"sim.dt_s={dt}", f"sim.control_period_s={control}"] + variant)
        if not why:
            note = ("the base case passes; the cases' verdicts decide (docs/theory/gimbal-servo.md)" if is_campaign(name)
                    else "passes: not shipped there?")
            return shipped, ok or "passes", wall, dt, f"{' '.join(variant)}: {note}"
        reasons.append(f"{variant[0].split('=')[1]} w_n {variant[1].split('=')[1]}: {why}")
    return shipped, ok or "passes", wall, dt, " / ".join(reasons)


def main() -> None:
    names = sys.argv[1:] or SCENARIOS
    print("| scenario | dt shipped [s] | as shipped | wall [s] | next dt tried [s] | what broke there |")
    print("|---|---:|---|---:|---:|---|")
    for name in names:
        shipped, status, wall, next_dt, why = frontier(name)
        print(f"| {name} | {shipped:g} | {status} | {wall:.1f} | {'-' if next_dt is None else f'{next_dt:g}'} | {why} |",
              flush=True)


if __name__ == "__main__":
    main()
