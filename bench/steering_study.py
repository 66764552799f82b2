"""docs/theory/steering.md, "Steering study": every steering law on the same random rest-to-rest slews.

Each slew starts at rest from the zero-momentum set (45, -45, -45, 45) deg of
reorient_near_singular's spacecraft (h = 20 N m s, beta'max = 30 deg/s): axis uniform on the
sphere, angle uniform in [30, 150] deg, duration 40 s x angle / 60 deg, so the program's peak
rate (1.5 angle / duration, SEEDS §004's cubic angle) and with it the peak |H| (about 2 h) are
the same for every angle; 5 s at rest before, 15 s after. With this h and duration about half
the plain min-max paths come within 1e-3 of a singular set (measured: docs/theory/steering.md "Steering study").
Every law flies the same slews and the table gives, per law: how many runs come within 1e-3 of
a singular set (min sqrt(det JJ')), the peak gimbal rate, the torque error, the final attitude
error, and every limit violation. `--limits` adds a 200 deg/s^2 acceleration limit and stops
at +-150 deg about each starting angle.

    .venv/bin/python bench/steering_study.py [--runs 200] [--workers 2] [--seed 14] [--limits] [--laws pinv,...]
                                              [--set KEY.PATH=VALUE ...]   (e.g. another inertia)
                                              [--csv runs/steering_study.csv] [--table-only]

The rows are written to the CSV after every batch of slews and a run started again with the same
options carries on from the slews already there (`--table-only` prints the table from the CSV).
About 3 CPU s per run (1200 runs for 200 slews; minimax_lp solves an LP per control step).
"""

from __future__ import annotations

import argparse
import copy
import csv
import json
from pathlib import Path

import numpy as np
import yaml

from testbed.cli.progress import advance_to, progress_bar
from testbed.scenario.loading import apply_override
from testbed.scenario.shipped_files import SCENARIO_DIR
from testbed.steering import STEERING_LAWS
from testbed.campaign.cases import Case
from testbed.campaign.rows import run_cases

BASE = "reorient_near_singular"
SEED = 14
START_S, SETTLE_S, SECONDS_PER_60_DEG = 5.0, 15.0, 40.0
ANGLE_RANGE_DEG = (30.0, 150.0)
START_ANGLES_DEG = (45.0, -45.0, -45.0, 45.0)
ACCELERATION_MAX_DEG_S2, TRAVEL_DEG = 200.0, 150.0
SINGULAR = 1e-3
VIOLATIONS = ("rate_limit_violations", "gimbal_acceleration_violations", "gimbal_angle_limit_violations")
COLUMNS = ("min_singularity_measure", "peak_gimbal_rate_deg_s", "torque_error_rel", "final_attitude_error_deg",
           "peak_gimbal_acceleration_deg_s2", *VIOLATIONS)


def slews(runs: int, seed: int = SEED) -> list[dict]:
    """The study's slews: {axis, angle_deg, duration_s, sim_s}, the same for every law. The axis
    is a normalised standard normal 3-vector (uniform on the sphere), the angle uniform."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(runs):
        axis = rng.normal(size=3)
        angle = float(rng.uniform(*ANGLE_RANGE_DEG))
        duration = SECONDS_PER_60_DEG * angle / 60.0
        out.append({"axis": (axis / np.linalg.norm(axis)).tolist(), "angle_deg": angle, "duration_s": duration,
                    "sim_s": float(np.ceil(START_S + duration + SETTLE_S))})
    return out


def limits() -> dict:
    """The `--limits` allocator options: the acceleration limit and stops +-TRAVEL_DEG about each start."""
    return {"gimbal_acceleration_max_deg_s2": ACCELERATION_MAX_DEG_S2,
            "gimbal_angle_limits_deg": [[a - TRAVEL_DEG, a + TRAVEL_DEG] for a in START_ANGLES_DEG]}


def study_cases(slew_indices, laws: list[str], with_limits: bool = False, overrides=(), seed: int = SEED) -> list[Case]:
    """One Case per (slew, law) on reorient_near_singular for the slews numbered `slew_indices`
    (an int n: the first n) of `slews(..., seed)`, ready for run_study; `overrides`
    ("key.path=value") apply first."""
    indices = range(slew_indices) if isinstance(slew_indices, int) else list(slew_indices)
    every = slews(max(indices, default=-1) + 1, seed)
    base = yaml.safe_load((SCENARIO_DIR / f"{BASE}.yaml").read_text())
    for override in overrides:
        apply_override(base, override)
    base["checks"] = {}   # the shipped scenario's bounds are about its own slew
    if base["model"]["gimbal_angles_deg"] != list(START_ANGLES_DEG):
        raise ValueError(f"{BASE} no longer starts at {START_ANGLES_DEG}: the study's stops are placed about it")
    cases = []
    for i in indices:
        slew = every[i]
        for j, law in enumerate(laws):
            data = copy.deepcopy(base)
            data["pipeline"]["law"] |= {"axis": slew["axis"], "angle_deg": slew["angle_deg"],
                                        "duration_s": slew["duration_s"], "start_s": START_S}
            data["pipeline"]["allocator"]["type"] = law
            if with_limits:
                data["pipeline"]["allocator"] |= limits()
            data["sim"]["duration_s"] = slew["sim_s"]
            # values are scenario paths (the engine reads each back from the built run); the
            # study's own labels ride along as derived cells
            cases.append(Case(i * len(laws) + j, {"pipeline.allocator.type": law}, data, f"{BASE} (study slew {i})",
                              derived={"slew": i, "law": law}))
    return cases


def run_study(cases: list[Case], workers: int, progress=None) -> list[dict]:
    """The study's one call to the sweep engine: a row per case, in case order."""
    return run_cases(cases, workers, progress=progress)


def write_csv(path: Path, rows: list[dict], first: list[str]) -> Path:
    """One line per run, the `first` columns first; floats written with repr (round-trip exact),
    missing cells empty."""
    names = list(first) + sorted({k for row in rows for k in row} - set(first))
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=names, restval="")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: repr(v) if isinstance(v, float) else v for k, v in row.items()})
    return path


def read_rows(path: Path) -> list[dict]:
    """Rows written by write_csv, the study's columns as numbers."""
    with open(path, newline="") as handle:
        rows = list(csv.DictReader(handle))
    for row in rows:
        row["slew"] = int(row["slew"])
        row.update({k: float(row[k]) if row.get(k) not in (None, "") else float("nan") for k in COLUMNS})
    return rows


def table(rows: list[dict], laws: list[str]) -> str:
    """The Markdown table of docs/theory/steering.md, one line per law (its finished runs)."""
    lines = ["| law | runs within 1e-3 of a singular set | min √det(JJᵀ) | peak gimbal rate median / max [deg/s] "
             "| torque error (rel. RMS) median / max | final att. error median / max [deg] | failed runs "
             "| rate / acceleration / angle violations |",
             "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for law in laws:
        mine = [r for r in rows if r["law"] == law]
        done = [r for r in mine if r["status"] == "ok"]
        if not done:
            lines.append(f"| {law} | 0 of 0 | | | | | {len(mine)} | |")
            continue
        m, peak, torque, final = (np.array([r[k] for r in done], dtype=float) for k in COLUMNS[:4])
        violations = " / ".join(f"{int(sum(r[k] for r in done))}" for k in VIOLATIONS)
        lines.append(f"| {law} | {int(np.sum(m < SINGULAR))} of {len(done)} | {m.min():.2g} "
                     f"| {np.median(peak):.3g} / {peak.max():.3g} | {np.median(torque):.2g} / {torque.max():.2g} "
                     f"| {np.median(final):.2g} / {final.max():.2g} | {len(mine) - len(done)} | {violations} |")
    return "\n".join(lines)


def peak_rate_ratios(rows: list[dict], laws: list[str], reference: str = "pinv", plain: str = "minimax") -> str:
    """Each law's peak gimbal rate over `reference`'s on the same slew (median of the per-slew
    ratio): on every slew both finished, and on the slews where the `plain` law's path stays
    >= SINGULAR from singular sets (min-max's advantage is a property of regular paths)."""
    peak = {(r["slew"], r["law"]): r["peak_gimbal_rate_deg_s"] for r in rows if r["status"] == "ok"}
    measure = {r["slew"]: r["min_singularity_measure"] for r in rows if r["law"] == plain and r["status"] == "ok"}
    clear = {s for s, m in measure.items() if m >= SINGULAR}
    lines = [f"| law | peak rate / {reference}'s, median: every slew | slews where {plain} stays >= {SINGULAR:g} "
             f"({len(clear)}) |", "|---|---:|---:|"]
    for law in laws:
        ratios = {s: peak[s, law] / peak[s, reference] for (s, name) in peak if name == law and (s, reference) in peak}
        on_clear = [v for s, v in ratios.items() if s in clear]
        cells = [f"{np.median(list(v)):.3g}" if len(v) else "" for v in (ratios.values(), on_clear)]
        lines.append(f"| {law} | {cells[0]} | {cells[1]} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=200, help="slews (each flown by every law)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--seed", type=int, default=SEED, help="of the random slews (the docs' table: 14)")
    parser.add_argument("--limits", action="store_true", help="add the acceleration limit and the stops")
    parser.add_argument("--laws", default=",".join(STEERING_LAWS))
    parser.add_argument("--set", action="append", default=[], metavar="KEY.PATH=VALUE")
    parser.add_argument("--csv", type=Path, default=Path("runs/steering_study.csv"))
    parser.add_argument("--batch", type=int, default=10, help="slews between two writes of the CSV")
    parser.add_argument("--table-only", action="store_true", help="print the table of the CSV, run nothing")
    args = parser.parse_args()
    laws = args.laws.split(",")
    rows = read_rows(args.csv) if args.csv.exists() else []
    if not args.table_only:
        options = {"seed": args.seed, "limits": args.limits, "set": args.set}
        sidecar = args.csv.with_suffix(".options.json")
        if rows and (not sidecar.exists() or json.loads(sidecar.read_text()) != options):
            parser.error(f"{args.csv} holds runs made with other options than {options}: give another --csv")
        args.csv.parent.mkdir(parents=True, exist_ok=True)
        sidecar.write_text(json.dumps(options))
        rows = [r for r in rows if r["law"] in laws and r["slew"] < args.runs]
        done = {(r["slew"], r["law"]) for r in rows}
        todo = [i for i in range(args.runs) if any((i, law) not in done for law in laws)]
        with progress_bar("steering study", len(todo) * len(laws), "runs") as bar:
            for start in range(0, len(todo), args.batch):
                cases = [c for c in study_cases(todo[start:start + args.batch], laws, args.limits, args.set, args.seed)
                         if (c.derived["slew"], c.derived["law"]) not in done]
                offset = bar.n
                rows += run_study(cases, args.workers, lambda n, total, failed: advance_to(bar, offset + n))
                write_csv(args.csv, sorted(rows, key=lambda r: (r["slew"], laws.index(r["law"]))), ["slew", "law"])
    print(table(rows, laws))
    if "pinv" in laws and "minimax" in laws:
        print()
        print(peak_rate_ratios(rows, laws))


if __name__ == "__main__":
    main()
