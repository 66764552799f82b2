"""The "Steering laws compared" table of docs/theory/steering.md: each steering law on the reorientation slews.

Runs reorient_minimax's slew (the one reorient_pinv also flies) and reorient_near_singular
with every steering allocator and prints a Markdown table of their metrics. About a minute
(minimax_lp solves one HiGHS LP per control step).

    .venv/bin/python bench/steering_table.py [--laws pinv,minimax,...]
"""

import argparse

from testbed.runner import run_scenario
from testbed.scenario.loading import load_scenario
from testbed.steering import STEERING_LAWS

COLUMNS = (("final_attitude_error_deg", "final att. error [deg]", ".2g"),
           ("max_tracking_error_deg", "max tracking error [deg]", ".3g"),
           ("peak_gimbal_rate_deg_s", "peak gimbal rate [deg/s]", ".3g"),
           ("min_singularity_measure", "min sqrt(det JJ')", ".2g"),
           ("min_scale", "min scale", ".3g"),
           ("torque_error_rel", "torque error (rel. RMS)", ".2g"),
           ("rate_limit_violations", "rate-limit violations", ".0f"))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--laws", default=",".join(STEERING_LAWS))
    args = parser.parse_args()
    print("| slew | law | " + " | ".join(c[1] for c in COLUMNS) + " |")
    print("|---|---|" + "---:|" * len(COLUMNS))
    for scenario_name, label in (("reorient_minimax", "60° about (1,1,1)/√3, h = 25"),
                                 ("reorient_near_singular", "60° about (1,-1,1)/√3, h = 20")):
        for law in args.laws.split(","):
            scenario = load_scenario(scenario_name, [f"pipeline.allocator.type={law}"])
            result = run_scenario(scenario, None)
            cells = " | ".join(format(result.metrics[key], fmt) for key, _, fmt in COLUMNS)
            print(f"| {label} | {law} | {cells} |", flush=True)


if __name__ == "__main__":
    main()
