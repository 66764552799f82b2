"""A campaign from its scenario to its folder: its cases loaded, planned and read back before
any runs, the table opened (fresh or resumed), the cases run into it on the engine, and the
summary written (docs/campaigns.md). The command line (`testbed sweep`, testbed.cli.campaign)
adds the arguments, the progress bar and the report.
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
from pathlib import Path

from testbed.errors import InputError, WriteFailed


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
    its row will hold: the read-back values, the names of its metrics and of its checks; how
    long it may run (testbed.campaign.case_timeout); and what batches it (testbed.campaign.batches):
    its timing and the memory of its world."""
    from testbed.metrics import available
    from testbed.campaign.batches import world_bytes
    from testbed.campaign.case_timeout import case_timeout_s
    from testbed.campaign.applied_values import applied_values, check_applied
    from testbed.run_core.plan import prepare

    plan = prepare(scenario)
    applied = applied_values(values, scenario, plan.plant, plan.pipeline.stages())
    check_applied(values, applied)
    return {"applied": applied, "metrics": available(scenario), "timeout_s": case_timeout_s(scenario),
            "timing": plan.timing, "world_bytes": world_bytes(plan),
            "checks": {name: {"max": limit.max, "min": limit.min} for name, limit in scenario.checks.items()}}


def load_cases(name: str, overrides: list[str], indices=None):
    """(scenario name, raw data, cases) of a sweep scenario, each case validated, built and read
    back; InputError if anything is bad."""
    from testbed.campaign.cases import expand

    name, data, source, _ = load_campaign(name, overrides)
    return name, data, expand(data, source, build_and_read_back, indices)


def check_case_traces(out: Path, cases) -> None:
    """Refuse (InputError naming --out) before anything runs a DIR/caseNNNN.rrd that is there but
    is not a file (a directory): it would fail only when its case is written."""
    from testbed.campaign.rows import case_trace
    from testbed.recording.output_paths import output_path

    for case in cases:
        path = case_trace(out, case.index)
        if os.path.lexists(path):  # a new file's folder is probed once, with the table's
            output_path(path)


def load_plugins_in_workers(engine, cases) -> None:
    """Every plug-in the cases name, imported in every worker before any case runs (InputError
    naming the plug-in and the worker if one cannot be)."""
    for entries, source in {(tuple(case.data.get("plugins") or ()), case.source) for case in cases}:
        if entries:
            engine.load_plugins(list(entries), str(Path(source).parent))


def summarise(name: str, data: dict, rows: list[dict], cases, out: Path, scenario: str,
              overrides: list[str]) -> list[str]:
    """Write DIR/summary/summary.json and summary.rrd of a finished campaign (testbed.campaign.stats,
    testbed.campaign.plots); returns the lines for the terminal. Each value of a grid field or
    a choice gets its own pass rate; `scenario` and `overrides` as the command was given them
    (for the rerun command the summary prints)."""
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
    grid = [key for key in spec.grid if key in rows[0]]
    result = summary(name, rows, metric_names, limits, rerun_command(scenario, overrides, str(out)), groups, grid)
    result["parameters"] = parameters
    summary_json, summary_rrd = summary_files(out)
    summary_json.parent.mkdir(exist_ok=True)  # apart from the cases' caseNNNN.rrd
    write_atomically(summary_json, json.dumps(result, indent=1))
    write_summary_rrd(summary_rrd, rows, metric_names, parameters, result)
    return report(result)


def summary_files(out: Path) -> tuple[Path, Path]:
    """Where a finished campaign's statistics go: DIR/summary/summary.json and summary.rrd."""
    return out / "summary" / "summary.json", out / "summary" / "summary.rrd"


def open_table(out: Path, name: str, data: dict, cases, overrides: list[str], resume: bool):
    """(the campaign's table in `out`, not started yet, the rows it holds by case): its columns
    those the cases' rows will have; a fresh table, or with --resume the one this campaign left
    there (`resume`). Writes nothing; a folder the campaign could not finish in is refused (an output
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
    identity = {"scenario": name, "set": list(overrides), "cases": len(cases), "fingerprint": fingerprint(data, cases)}
    table = CampaignTable(out, file_stem(name), columns, identity, {"status": STATUSES},
                          {case.index: identity_cells(case) for case in cases})
    return table, table.read(resume)


def run_into(table, done: dict, cases, engine, rrd_dir: Path | None, case_timeout_s: float | None,
             progress=None, batch_size: int | None = None) -> list[dict]:
    """Run the cases the table does not hold yet (`done`), in batches of at most `batch_size`
    (testbed.campaign.rows.run_cases), each row into it as its batch finishes; on Ctrl-C (or
    any failure) the table is closed with every finished row, then the stop goes on. `progress`: a context manager (a progress bar, closed before a stop is
    reported) whose value is called as `advance(cases finished, of which failed)`, counting the
    rows held before."""
    from testbed.campaign.rows import run_cases

    todo = [case for case in cases if case.index not in done]
    failed_before = sum(not row["passed"] for row in done.values())
    try:
        with progress if progress is not None else contextlib.nullcontext() as advance:
            if advance is not None:
                advance(len(done), failed_before)
            run_cases(todo, rrd_dir=rrd_dir, on_row=table.append, engine=engine, case_timeout_s=case_timeout_s,
                      batch_size=batch_size,
                      progress=None if advance is None else
                      lambda count, total, failed: advance(len(done) + count, failed_before + failed))
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


def rerun_case(scenario: str, overrides: list[str], index: int, folder_of):
    """(campaign name, case, its trace's path, its row): case `index` of the campaign alone, in this
    process, its trace written to the folder `folder_of(campaign name)` (InputError for a number
    no case has)."""
    from testbed.campaign.rows import case_trace, run_case
    from testbed.recording.output_paths import output_path

    name, _, _, spec = load_campaign(scenario, overrides)
    if not 0 <= index < spec.count:
        raise InputError("--case", f"must be a case number 0 ... {spec.count - 1}, got {index}")
    _, _, (case,) = load_cases(scenario, overrides, [index])
    rrd = output_path(case_trace(folder_of(name), case.index))
    return name, case, rrd, run_case(case, str(rrd), raises=(WriteFailed,))  # a full disk: one line, exit 1
