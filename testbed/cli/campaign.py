"""`testbed sweep` (also `testbed campaign`): run every case of a scenario's `sweep:` block, in
parallel, into a table; or rerun one case alone.

    testbed sweep SCENARIO [--workers N | --scheduler tcp://HOST:PORT] [--out DIR] [--resume]
                           [--case-timeout SECONDS] [--rrd] [--set KEY.PATH=VALUE] [--json]
    testbed sweep SCENARIO --case N [--out DIR] [--set ...] [--json]

Every case is validated and built (and what it would run with read back, testbed.campaign.applied_values)
before the first one runs. The cases run on Dask (testbed.campaign.engine): a local cluster of
--workers processes started inside the command, or the cluster whose scheduler is at
--scheduler. Each row goes to DIR/<scenario>.csv and .parquet as its case finishes (default
DIR: runs/<scenario>_sweep; testbed.campaign.table); Ctrl-C keeps them, --resume runs only the
cases the table lacks. At the end DIR/summary/ gets summary.json and summary.rrd
(testbed.campaign.stats, testbed.campaign.plots), and the terminal the statistics; with --rrd
each case also writes DIR/caseNNNN.rrd. `--case N` rebuilds case N alone from the campaign
seed, runs it in this process (bit for bit the numbers of its row) and writes
DIR/caseNNNN.rrd. `--set` changes the base scenario before the sweep expands (the sweep block
too). Exit 0 when every case passed all its checks, 1 otherwise, 2 for bad input (nothing
runs or is written), 130 on Ctrl-C.
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
from pathlib import Path

from testbed.cli.commands import EXIT_FAILED, EXIT_OK, command, reported
from testbed.errors import InputError, WriteFailed, quoted
from testbed.cli.json_stdout import reserved_for_json
from testbed.cli.progress import advance_to, progress_bar


@command("sweep")
def add_parser(subparsers) -> None:
    p = subparsers.add_parser("sweep", aliases=["campaign"],
                              help="run a scenario's sweep or Monte Carlo campaign in parallel into a table")
    p.add_argument("scenario", help="scenario file or name in scenarios/ (with a sweep: block)")
    p.add_argument("--workers", type=int, default=None,
                   help="worker processes of the local cluster (default: one per core)")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                   help="run on the Dask cluster of this scheduler instead of a local one")
    p.add_argument("--case-timeout", metavar="SECONDS", default=None,
                   help="give up on a case that runs longer (twice: an error row); default from the "
                        "scenario: 60 s + 1 ms per physics step")
    p.add_argument("--out", help="output directory (default runs/<scenario>_sweep)")
    p.add_argument("--rrd", action="store_true", help="also write one .rrd per case")
    p.add_argument("--case", type=int, default=None, metavar="N",
                   help="rerun case N alone (in this process) and write its .rrd")
    p.add_argument("--resume", action="store_true",
                   help="keep the rows the same campaign left in the folder and run only the other cases")
    p.add_argument("--set", action="append", default=[], metavar="KEY.PATH=VALUE",
                   help="override a field of the base scenario before expanding")
    p.add_argument("--json", action="store_true", help="print the rows as one JSON list")
    p.set_defaults(func=run)


def load_campaign(name: str, overrides: list[str]):
    """(scenario name, raw data with the overrides applied, its source path, sweep spec)."""
    from testbed.scenario.loading import apply_override, read_yaml, resolve_path
    from testbed.campaign.spec import load_spec

    path = resolve_path(name).resolve()  # its plug-in paths are relative to it, in any worker's cwd
    data = read_yaml(path)
    for assignment in overrides:
        apply_override(data, assignment)
    return str(data.get("name", path.stem)), data, str(path), load_spec(data.get("sweep"))


def build_and_read_back(scenario, values: dict) -> dict:
    """Plan a case as its run will (testbed.run_core.plan.prepare) and check that every value set
    reaches the built plant and stages (testbed.campaign.applied_values.NotApplied otherwise); returns what
    its row will hold: the read-back values, the names of its metrics and of its checks; and how
    long it may run (testbed.campaign.case_timeout)."""
    from testbed.metrics import available
    from testbed.campaign.case_timeout import case_timeout_s
    from testbed.campaign.applied_values import applied_values, check_applied
    from testbed.run_core.plan import prepare

    plan = prepare(scenario)
    applied = applied_values(values, scenario, plan.plant, plan.pipeline.stages())
    check_applied(values, applied)
    return {"applied": applied, "metrics": available(scenario), "timeout_s": case_timeout_s(scenario),
            "checks": {name: {"max": limit.max, "min": limit.min} for name, limit in scenario.checks.items()}}


def load_cases(name: str, overrides: list[str], indices=None):
    """(scenario name, raw data, cases) of a sweep scenario, each case validated, built and read
    back; InputError if anything is bad."""
    from testbed.campaign.cases import expand

    name, data, source, _ = load_campaign(name, overrides)
    return name, data, expand(data, source, build_and_read_back, indices)


def output_folder(args, name: str) -> Path:
    """The campaign's folder, absolute (resolved once here, so that a case whose stage changes its
    worker's cwd cannot send another case's files elsewhere; a symlink, dangling too, is
    written through), refused before anything runs unless it can be written."""
    from testbed.recording.output_paths import file_stem, output_path

    given = Path(args.out) if args.out else Path("runs") / f"{file_stem(name)}_sweep"
    try:
        out = given.expanduser().resolve(strict=False)
    except (OSError, RuntimeError, ValueError) as exc:  # a symlink loop, a NUL byte
        raise InputError("--out", f"cannot write {quoted(str(given))}: {getattr(exc, 'strerror', None) or exc}") from None
    output_path(out / f"{file_stem(name)}.csv")  # probes that a file can be created there (not under a file)
    return out


def check_case_traces(out: Path, cases) -> None:
    """Refuse (InputError naming --out) before anything runs a DIR/caseNNNN.rrd that is there but
    is not a file (a directory): it would fail only when its case is written."""
    from testbed.campaign.rows import case_trace
    from testbed.recording.output_paths import output_path

    for case in cases:
        path = case_trace(out, case.index)
        if os.path.lexists(path):  # a new file's folder is probed once, with the table's
            output_path(path)


def run(args) -> int:
    from testbed.campaign.case_timeout import checked_case_timeout
    from testbed.campaign.engine import Engine

    case_timeout = checked_case_timeout(args.case_timeout) if args.case_timeout is not None else None
    engine = Engine(args.workers, args.scheduler)  # checks --workers; started below
    if args.case is not None:
        return _rerun_case(args)
    # a plug-in's prints go to stderr, the workers' too (they inherit it as their stdout)
    with reserved_for_json(args.json):
        name, data, cases = load_cases(args.scenario, args.set)
        out = output_folder(args, name)
        table, done = open_table(out, name, data, cases, args)  # refuses a damaged folder; writes nothing
        if args.rrd:
            check_case_traces(out, cases)
        clamped = engine.at_most(len(cases))
        with engine:  # an unreachable scheduler is refused before any file is written
            _load_plugins_in_workers(engine, cases)
            if clamped:  # after the start: a refused start is its one line
                print(f"note: --workers {args.workers} for {len(cases)} cases: started {len(cases)}", file=sys.stderr)
            table.start()
            rows = _run_into(table, done, cases, engine, out if args.rrd else None, args, case_timeout)
        lines = summarise(name, data, rows, cases, out, args)

    def report():
        if args.json:
            print(json.dumps(rows))
            return
        passed = sum(r["passed"] for r in rows)
        print(f"sweep {name}: {len(rows)} cases, {passed} passed, {len(rows) - passed} failed; "
              f"table {table.csv_path} (and .parquet), summary in {out / 'summary'}")
        print("\n".join(lines))
    return reported(EXIT_OK if all(r["passed"] for r in rows) else EXIT_FAILED, report)


def _load_plugins_in_workers(engine, cases) -> None:
    """Every plug-in the cases name, imported in every worker before any case runs (InputError
    naming the plug-in and the worker if one cannot be)."""
    for entries, source in {(tuple(case.data.get("plugins") or ()), case.source) for case in cases}:
        if entries:
            engine.load_plugins(list(entries), str(Path(source).parent))


def summarise(name: str, data: dict, rows: list[dict], cases, out: Path, args) -> list[str]:
    """Write DIR/summary/summary.json and summary.rrd of a finished campaign (testbed.campaign.stats,
    testbed.campaign.plots); returns the lines for the terminal. Each value of a grid field or
    a choice gets its own pass rate."""
    from testbed.campaign.plots import write_summary_rrd
    from testbed.campaign.stats import report, rerun_command, summary
    from testbed.recording.atomic_file import write_atomically
    from testbed.campaign.rows import flat
    from testbed.campaign.spec import load_spec

    spec = load_spec(data.get("sweep"))
    choices = [key for key, dist in spec.drawn.items() if dist.kind == "choice"]
    groups = [key for key in [*spec.grid, *choices] if key in rows[0]]  # a value's own column (not a vector)
    metric_names = list(dict.fromkeys(m for case in cases for m in case.prepared["metrics"]))
    parameters = list(dict.fromkeys(k for case in cases for k in [*flat(case.values), *case.derived]))
    limits = {case.index: case.prepared["checks"] for case in cases}
    result = summary(name, rows, metric_names, limits, rerun_command(args.scenario, args.set, str(out)), groups)
    result["parameters"] = parameters
    summary_json, summary_rrd = summary_files(out)
    summary_json.parent.mkdir(exist_ok=True)  # apart from the cases' caseNNNN.rrd
    write_atomically(summary_json, json.dumps(result, indent=1))
    write_summary_rrd(summary_rrd, rows, metric_names, parameters, result)
    return report(result)


def summary_files(out: Path) -> tuple[Path, Path]:
    """Where a finished campaign's statistics go: DIR/summary/summary.json and summary.rrd."""
    return out / "summary" / "summary.json", out / "summary" / "summary.rrd"


def open_table(out: Path, name: str, data: dict, cases, args):
    """(the campaign's table in `out`, not started yet, the rows it holds by case): its columns
    those the cases' rows will have; a fresh table, or with --resume the one this campaign left
    there. Writes nothing; a folder the campaign could not finish in is refused (an output
    path of the wrong kind, a damaged table: testbed.campaign.table)."""
    from testbed.campaign.table import CampaignTable, fingerprint, merge_kinds
    from testbed.accuracy.guard import CHECK_NAMES as GUARD_CHECKS
    from testbed.campaign.rows import expected_row, identity_cells
    from testbed.run_core.result import STATUSES
    from testbed.recording.output_paths import file_stem, output_path

    for path in summary_files(out):
        output_path(path)  # written only when every case has run

    columns: dict = {}
    for case in cases:
        merge_kinds(columns, expected_row(case, case.prepared["applied"], case.prepared["metrics"],
                                          [*case.prepared["checks"], *GUARD_CHECKS]))  # a guard's cell: FAIL or empty
    identity = {"scenario": name, "set": list(args.set), "cases": len(cases), "fingerprint": fingerprint(data, cases)}
    table = CampaignTable(out, file_stem(name), columns, identity, {"status": STATUSES},
                          {case.index: identity_cells(case) for case in cases})
    return table, table.read(args.resume)


def _run_into(table, done: dict, cases, engine, rrd_dir: Path | None, args, case_timeout_s: float | None) -> list[dict]:
    """Run the cases the table does not hold yet (`done`), each row into it as its case
    finishes; on Ctrl-C (or any failure) the table is closed with every finished row, then the
    stop goes on."""
    from testbed.campaign.rows import run_cases

    todo = [case for case in cases if case.index not in done]
    failed_before = sum(not row["passed"] for row in done.values())
    try:
        with progress_bar(f"sweep {table.csv_path.stem}", len(cases), "cases") as bar:
            bar.disable = bar.disable or args.json
            advance_to(bar, len(done), failed=failed_before)
            run_cases(todo, rrd_dir=rrd_dir, on_row=table.append, engine=engine, case_timeout_s=case_timeout_s,
                      progress=lambda count, total, failed: advance_to(bar, len(done) + count, failed=failed_before + failed))
        return table.close()
    except WriteFailed as exc:  # a full disk: one line, the rows the CSV holds are kept for --resume
        with contextlib.suppress(WriteFailed):
            table.close()
        raise WriteFailed(exc.path, f"{exc.reason}; {len(table.rows)} of {len(cases)} cases are kept in "
                                    f"{table.csv_path}; --resume completes it once there is room") from None
    except BaseException:
        try:
            rows = table.close()
        except WriteFailed:  # the stop goes on; the CSV holds every row appended
            rows = list(table.rows)
        print(f"stopped: {len(rows)} of {len(cases)} cases finished, kept in {table.csv_path} and "
              f"{table.parquet_path.name}; --resume runs the other {len(cases) - len(rows)}", file=sys.stderr)
        raise


def _rerun_case(args) -> int:
    """`--case N`: case N alone, in this process, its trace written."""
    from testbed.campaign.rows import case_trace, run_case
    from testbed.recording.output_paths import output_path

    with reserved_for_json(args.json):  # a plug-in's prints go to stderr
        name, _, _, spec = load_campaign(args.scenario, args.set)
        if not 0 <= args.case < spec.count:
            raise InputError("--case", f"must be a case number 0 ... {spec.count - 1}, got {args.case}")
        _, _, (case,) = load_cases(args.scenario, args.set, [args.case])
        rrd = output_path(case_trace(output_folder(args, name), case.index))
        row = run_case(case, str(rrd), raises=(WriteFailed,))  # a full disk: one line, exit 1

    def report():
        if args.json:
            print(json.dumps(row))
            return
        print(f"case {case.index} of {name} (seed {case.seed}): {row['status']}"
              f"{'' if row['passed'] else ': ' + row['cause']}")
        for key, value in row.items():
            if key not in ("case", "status", "passed", "error", "cause", "seed"):
                print(f"  {key:44s} {value}")
        print(f"trace: {rrd}")
    return reported(EXIT_OK if row["passed"] else EXIT_FAILED, report)
