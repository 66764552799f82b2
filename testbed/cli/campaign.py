"""`testbed sweep` (also `testbed campaign`): run every case of a scenario's `sweep:` block, in
parallel, into a table; or rerun one case alone.

    testbed sweep SCENARIO [--workers N | --scheduler tcp://HOST:PORT] [--out DIR] [--resume]
                           [--case-timeout SECONDS] [--batch-size N] [--rrd] [--set KEY.PATH=VALUE] [--json]
    testbed sweep SCENARIO --case N [--out DIR] [--set ...] [--json]

Every case is validated and built (and what it would run with read back, testbed.campaign.applied_values)
before the first one runs. The cases run on Dask (testbed.campaign.engine): a local cluster of
--workers processes started inside the command, or the cluster whose scheduler is at
--scheduler, in batches of cases stepped in lockstep (testbed.campaign.batches; --batch-size 1:
each case alone). Each row goes to DIR/<scenario>.csv and .parquet as its case finishes (default
DIR: runs/<scenario>_sweep; testbed.campaign.table); Ctrl-C keeps them, --resume runs only the
cases the table lacks. At the end DIR/summary/ gets summary.json and summary.rrd
(testbed.campaign.stats, testbed.campaign.plots), and the terminal the statistics; with --rrd
each case also writes DIR/caseNNNN.rrd. `--case N` rebuilds case N alone from the campaign
seed, runs it alone in this process (the numbers of its row: bit for bit where every stage
ran per world in its batch, else to the batched stages' round-off) and writes
DIR/caseNNNN.rrd. `--set` changes the base scenario before the sweep expands (the sweep block
too). Exit 0 when every case passed all its checks, 1 otherwise, 2 for bad input (nothing
runs or is written), 130 on Ctrl-C.
"""

from __future__ import annotations

import contextlib
import json
import sys
from pathlib import Path

from testbed.campaign.orchestration import load_cases  # noqa: F401  (where code has imported it from)
from testbed.cli.commands import EXIT_FAILED, EXIT_OK, command, reported
from testbed.errors import InputError, quoted
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
    p.add_argument("--batch-size", metavar="N", default=None,
                   help="at most N cases stepped together in one task (default: as many as fit "
                        "512 MiB, spread over the workers; 1: each case alone)")
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


def run(args) -> int:
    from testbed.campaign.batches import checked_batch_size
    from testbed.campaign.case_timeout import checked_case_timeout
    from testbed.campaign.engine import Engine
    from testbed.campaign.orchestration import (check_case_traces, load_plugins_in_workers, open_table, run_into,
                                                summarise)

    case_timeout = checked_case_timeout(args.case_timeout) if args.case_timeout is not None else None
    batch_size = checked_batch_size(args.batch_size) if args.batch_size is not None else None
    engine = Engine(args.workers, args.scheduler)  # checks --workers; started below
    if args.case is not None:
        return _rerun_case(args)
    # a plug-in's prints go to stderr, the workers' too (they inherit it as their stdout)
    with reserved_for_json(args.json):
        name, data, cases = load_cases(args.scenario, args.set)
        out = output_folder(args, name)
        # refuses a damaged folder; writes nothing
        table, done = open_table(out, name, data, cases, args.set, args.resume)
        if args.rrd:
            check_case_traces(out, cases)
        clamped = engine.at_most(len(cases))
        with engine:  # an unreachable scheduler is refused before any file is written
            load_plugins_in_workers(engine, cases)
            if clamped:  # after the start: a refused start is its one line
                print(f"note: --workers {args.workers} for {len(cases)} cases: started {len(cases)}", file=sys.stderr)
            table.start()
            rows = run_into(table, done, cases, engine, out if args.rrd else None, case_timeout,
                            _cases_bar(table.csv_path.stem, len(cases), args.json), batch_size)
        lines = summarise(name, data, rows, cases, out, args.scenario, args.set)

    def report():
        if args.json:
            print(json.dumps(rows))
            return
        passed = sum(r["passed"] for r in rows)
        print(f"sweep {name}: {len(rows)} cases, {passed} passed, {len(rows) - passed} failed; "
              f"table {table.csv_path} (and .parquet), summary in {out / 'summary'}")
        print("\n".join(lines))
    return reported(EXIT_OK if all(r["passed"] for r in rows) else EXIT_FAILED, report)


@contextlib.contextmanager
def _cases_bar(name: str, total: int, quiet: bool):
    """The campaign's progress bar; its value advances it to (cases finished, of which failed)."""
    with progress_bar(f"sweep {name}", total, "cases") as bar:
        bar.disable = bar.disable or quiet
        yield lambda count, failed: advance_to(bar, count, failed=failed)


def _rerun_case(args) -> int:
    """`--case N`: case N alone, in this process, its trace written."""
    from testbed.campaign.orchestration import rerun_case

    with reserved_for_json(args.json):  # a plug-in's prints go to stderr
        name, case, rrd, row = rerun_case(args.scenario, args.set, args.case, lambda name: output_folder(args, name))

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
