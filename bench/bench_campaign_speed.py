"""A campaign as shipped against another configuration, side by side: wall time and verdicts.

    .venv/bin/python bench/bench_campaign_speed.py lebedev_spinup_campaign --samples 8

Runs `testbed campaign NAME --set sweep.samples=N --workers 2` as shipped and with the other
configuration's overrides (`--candidate`; by default BEFORE, the campaigns' configuration before
the frontier steps: dt 0.002 s, the intvelocity servo at 316 rad/s, docs/theory/gimbal-servo.md),
alternating the two `--repeat` times so that load from other processes hits both alike, and
prints the median wall time of each, their ratio (goal for the flagship's campaign: shipped
<= 1/3 of before), and every case whose verdict differs, with the checks that differ.
"""

from __future__ import annotations

import argparse
import csv
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


BEFORE = ["sim.dt_s=0.002", "model.servo_model=intvelocity", "model.servo_natural_frequency_rad_s=316"]


def campaign(name: str, samples: int, overrides: list[str], out: Path) -> tuple[float, dict]:
    """(wall seconds, rows by case) of one campaign run into `out`."""
    argv = [sys.executable, "-m", "testbed", "campaign", name, "--workers", "2", "--out", str(out),
            "--set", f"sweep.samples={samples}"] + [a for o in overrides for a in ("--set", o)]
    wall0 = time.perf_counter()
    subprocess.run(argv, check=False, capture_output=True)
    wall = time.perf_counter() - wall0
    table = next(out.glob("*.csv"))
    return wall, {row["case"]: row for row in csv.DictReader(table.open())}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("scenario")
    parser.add_argument("--samples", type=int, default=8)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--candidate", nargs="+", metavar="KEY=VALUE", default=BEFORE)
    args = parser.parse_args()
    walls = {"shipped": [], "candidate": []}
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.repeat):
            for kind, overrides in (("shipped", []), ("candidate", args.candidate)):
                wall, rows[kind] = campaign(args.scenario, args.samples, overrides, Path(tmp) / f"{kind}{k}")
                walls[kind].append(wall)
    shipped, candidate = statistics.median(walls["shipped"]), statistics.median(walls["candidate"])
    print(f"{args.scenario}, {len(rows['shipped'])} cases on 2 workers, median of {args.repeat} alternating runs")
    print(f"  shipped   {shipped:7.1f} s wall")
    print(f"  candidate {candidate:7.1f} s wall  ({' '.join(args.candidate)})")
    print(f"  shipped / candidate {shipped / candidate:.3f}  (goal for the flagship campaign against BEFORE: <= 0.333)")
    changed = [case for case in rows["shipped"] if rows["shipped"][case]["passed"] != rows["candidate"][case]["passed"]]
    print(f"  verdicts that differ: {len(changed)}")
    for case in changed:
        a, b = rows["shipped"][case], rows["candidate"][case]
        checks = [k for k in a.keys() | b.keys() if k.startswith("check:") and a.get(k, "") != b.get(k, "")]
        why = ", ".join(f"{k[6:]} {a.get(k) or '-'} -> {b.get(k) or '-'}" for k in sorted(checks))
        print(f"  case {case}: passed {a['passed']} -> {b['passed']}: {why}")


if __name__ == "__main__":
    main()
