"""`testbed sweep`: run every case of a scenario's `sweep:` block, in parallel, into a CSV.

    testbed sweep SCENARIO [--workers N] [--out DIR] [--rrd] [--set KEY.PATH=VALUE] [--json]

Writes DIR/<scenario>.csv (default DIR: runs/<scenario>_sweep), one row per case: the swept
values, status (ok | diverged | error), passed, error, wall time, every metric and every
check (pass/FAIL); with --rrd also DIR/caseNNNN.rrd per case. A progress line shows on a
terminal. `--set` changes the base scenario before the sweep expands (the sweep block too).
Exit 0 when every case passed all its checks, 1 otherwise, 2 for bad input (nothing runs).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from testbed.commands import command
from testbed.errors import InputError
from testbed.progress import advance_to, progress_bar

EXIT_OK, EXIT_FAILED = 0, 1


@command("sweep")
def add_parser(subparsers) -> None:
    p = subparsers.add_parser("sweep", help="run a scenario's sweep cases in parallel and write a CSV table")
    p.add_argument("scenario", help="scenario file or name in scenarios/ (with a sweep: block)")
    p.add_argument("--workers", type=int, default=None, help="parallel processes (default: CPU count)")
    p.add_argument("--out", help="output directory (default runs/<scenario>_sweep)")
    p.add_argument("--rrd", action="store_true", help="also write one .rrd per case")
    p.add_argument("--set", action="append", default=[], metavar="KEY.PATH=VALUE",
                   help="override a field of the base scenario before expanding")
    p.add_argument("--json", action="store_true", help="print the rows as one JSON list")
    p.set_defaults(func=run)


def load_cases(name: str, overrides: list[str]):
    """(scenario name, swept fields, cases) of a sweep scenario; InputError if anything is bad."""
    from testbed.scenario import apply_override, read_yaml, resolve_path
    from testbed.sweep import expand
    from testbed.sweep_spec import load_spec

    path = resolve_path(name)
    data = read_yaml(path)
    for assignment in overrides:
        apply_override(data, assignment)
    fields = load_spec(data.get("sweep")).fields
    return str(data.get("name", path.stem)), fields, expand(data, str(path))


def run(args) -> int:
    from testbed.runner import prepare
    from testbed.scenario import parse
    from testbed.sweep_runner import run_cases, write_csv
    from testbed.trace import file_stem, output_path

    workers = args.workers if args.workers is not None else (os.cpu_count() or 1)
    if workers < 1:
        raise InputError("--workers", f"must be >= 1, got {workers}")
    name, fields, cases = load_cases(args.scenario, args.set)
    for case in cases:  # every case must fit its system before the first one runs
        try:
            prepare(parse(case.data, case.source))
        except InputError as exc:
            raise InputError(f"sweep case {case.index}", f"({case.label}) {exc.field}: {exc.reason}") from None
    out = Path(args.out) if args.out else Path("runs") / f"{file_stem(name)}_sweep"
    output_path(out / f"{file_stem(name)}.csv")  # a sweep writes a folder: refused if a file is in the way
    with progress_bar(f"sweep {name}", len(cases), "cases") as bar:
        bar.disable = bar.disable or args.json
        rows = run_cases(cases, workers, out if args.rrd else None,
                         lambda done, total, failed: advance_to(bar, done, failed=failed))
    csv_path = write_csv(out / f"{file_stem(name)}.csv", rows, fields)
    if args.json:
        print(json.dumps(rows))
    else:
        passed = sum(r["passed"] for r in rows)
        print(f"sweep {name}: {len(rows)} cases, {passed} passed, {len(rows) - passed} failed; table {csv_path}")
        for r in rows:
            if not r["passed"]:
                failed = [k.split(":", 1)[1] for k, v in r.items() if k.startswith("check:") and v == "FAIL"]
                why = r.get("error") or f"failed checks: {', '.join(failed)}"
                print(f"  case {r['case']} ({', '.join(f'{f}={r[f]}' for f in fields)}): {r['status']}: {why}")
    return EXIT_OK if all(r["passed"] for r in rows) else EXIT_FAILED
