"""Sweep one parameter of a scenario through the Python API and print a table of metrics.

Notebook-style: run it as a script, or cell by cell (`# %%`) in an editor that knows cells.

    .venv/bin/python examples/sweep_gain.py
    .venv/bin/python examples/sweep_gain.py --param pipeline.allocator.beta_rate_max_deg_s \
        --values 6 8 10 --metric user_min_scale --set sim.duration_s=60

By default it runs examples/pd_steering.yaml (the user's quaternion PD law on the 4-CMG bus)
for five natural frequencies of the law: a stiffer law settles sooner but asks the gimbals
for more rate than the 8 deg/s limit, so the weighted pseudo-inverse scales its command down
(min scale < 1) and delivers less of the wanted torque (torque error > 0). The table shows
metrics, not the scenario's checks, whose bounds were set for 0.1 rad/s.
Every value is one `--set`-style override, validated like the file; nothing is written to disk.
Only the public API is used (`testbed.load`, `testbed.run`, `RunResult.metrics`).
"""

# %% What to sweep
import argparse
import sys
from pathlib import Path

import testbed

HERE = Path(__file__).resolve().parent
SCENARIO = HERE / "pd_steering.yaml"
PARAMETER = "pipeline.law.natural_frequency_rad_s"
VALUES = [0.05, 0.075, 0.1, 0.15, 0.2]
METRICS = ["user_final_attitude_error_deg", "user_peak_gimbal_rate_deg_s", "user_min_scale", "user_torque_error_rel"]


def sweep(scenario, parameter: str, values, extra: list[str] = ()) -> list[tuple[float, testbed.RunResult]]:
    """One run per value: load (with the overrides), run, keep the result (its metrics, checks, trace)."""
    results = []
    for value in values:
        loaded = testbed.load(scenario, [*extra, f"{parameter}={value}"])
        results.append((value, testbed.run(loaded)))
    return results


def table(parameter: str, results, metrics: list[str]) -> str:
    """The results as a fixed-width text table: the swept value, the run's status and each metric (%.6g)."""
    name = parameter.rsplit(".", 1)[-1]
    header = [name, "status"] + list(metrics)
    rows = [[f"{value:g}", r.status]
            + [f"{r.metrics[m]:.6g}" if m in r.metrics else "-" for m in metrics] for value, r in results]
    widths = [max(len(str(row[i])) for row in [header] + rows) for i in range(len(header))]
    return "\n".join("  ".join(cell.rjust(width) for cell, width in zip(row, widths)) for row in [header] + rows)


# %% Run it
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default=str(SCENARIO), help="scenario file or name")
    parser.add_argument("--param", default=PARAMETER, help="dotted path of the field to sweep")
    parser.add_argument("--values", nargs="+", type=float, default=VALUES)
    parser.add_argument("--metric", nargs="+", default=METRICS, help="metrics to tabulate")
    parser.add_argument("--set", action="append", default=[], metavar="KEY.PATH=VALUE",
                        help="a further override applied to every run")
    args = parser.parse_args(argv)
    try:
        results = sweep(args.scenario, args.param, args.values, args.set)
    except testbed.InputError as exc:  # a bad field or value: one line, like the command line
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"{args.scenario}: {args.param}")
    print(table(args.param, results, args.metric))
    return 0


if __name__ == "__main__":
    sys.exit(main())
