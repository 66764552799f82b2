"""Run the cases of a sweep or campaign on the engine (testbed.campaign.engine), one row each.

A row is everything a case did, never an exception: `case`, the values set (a list of numbers
as one column per component, `path[i]`), `status` (ok | diverged | method_failed | error), `passed`, `error`,
`cause` (why it failed: its error, or the checks it failed with their values),
`wall_s` (of a case run in a batch, its share: the batch's wall time over its cases), the
case's `seed`, derived columns (a misalignment angle), the values read back from
the built plant and stages (`applied:path`, testbed.campaign.applied_values), every metric and every check
(`check:NAME` pass/FAIL). A case whose read-back differs from what was set stops before its
first step with status error.
"""

from __future__ import annotations

import json
import math
import time
import traceback
from pathlib import Path
from typing import Callable

from testbed.errors import described, error_line
from testbed.interrupts import from_a_signal
from testbed.scenario.schema import is_number
from testbed.campaign.cases import Case



def flat(values: dict, prefix: str = "") -> dict:
    """Row cells of `values`: a list of numbers becomes `key[i]` per component, a mapping or a
    list of anything else its JSON text, a number, string or bool itself."""
    cells = {}
    for key, value in values.items():
        if isinstance(value, (list, tuple)) and value and all(is_number(v) for v in value):
            cells.update({f"{prefix}{key}[{i}]": v for i, v in enumerate(value)})
        elif isinstance(value, (list, tuple, dict)):
            cells[f"{prefix}{key}"] = json.dumps(value)
        else:
            cells[f"{prefix}{key}"] = value
    return cells


def failure_cause(status: str, error: str, checks: list[dict]) -> str:
    """Why a case did not pass, on one line: a run that stopped early, its error (a diverged
    plant, a method that left its validity, a stage's failure: testbed.run_core.result.RunResult); a run
    that ended, the checks it failed with their values and limits; "" when it passed."""
    if status != "ok":
        return error
    failed = [f"{c['name']} = {c['value']:.3g} ({c['limit']})" if isinstance(c["value"], float)
              else f"{c['name']} = {c['value']} ({c['limit']})" for c in checks if not c["passed"]]
    return error_line("fails " + "; ".join(failed)) if failed else ""


def case_row(case: Case, applied: dict, status: str = "", passed: bool = False, error: str = "",
             wall_s: float | None = None, results: dict | None = None, cause: str | None = None) -> dict:
    """The row of `case` (module doc); `applied`: testbed.campaign.applied_values.applied_values, `results`:
    the metrics and the `check:NAME` cells; `cause`: why it failed (`failure_cause`), by default its error."""
    return ({"case": case.index, **flat(case.values), "status": status, "passed": passed, "error": error,
             "cause": error if cause is None else cause, "wall_s": wall_s, "seed": case.seed, **case.derived}
            | flat({path: value for path, (value, _) in applied.items()}, "applied:") | (results or {}))


def identity_cells(case: Case) -> dict:
    """The cells of `case`'s row that its index, seed and values fix, whatever its run did (a
    row of another case, or edited, differs in one of them)."""
    return {"case": case.index, **flat(case.values), "seed": case.seed, **case.derived}


def expected_row(case: Case, applied: dict, metric_names, check_names) -> dict:
    """The cells `case`'s row will hold, each with a placeholder of its kind (a table's columns)."""
    return case_row(case, applied, wall_s=0.0, results={name: math.nan for name in metric_names}
                    | {f"check:{name}": "" for name in check_names})


def case_trace(folder: Path, index: int) -> Path:
    """Where case `index` of a campaign writes its trace: DIR/caseNNNN.rrd."""
    return Path(folder) / f"case{index:04d}.rrd"


def run_case(case: Case, rrd: str | None = None, raises: tuple[type[BaseException], ...] = ()) -> dict:
    """Run one case (its trace to `rrd` if given) and return its row (see module doc); an
    exception of `raises` goes to the caller instead (`--case N`: a trace that could not be
    written is its command's failure, not a row)."""
    from testbed.campaign.applied_values import applied_values, check_applied
    from testbed.run_core.in_progress import run_scenario
    from testbed.scenario.loading import parse

    wall0 = time.perf_counter()
    applied: dict = {}

    def read_back(plant, pipeline):
        applied.update(applied_values(case.values, scenario, plant, pipeline.stages()))
        check_applied(case.values, applied)

    try:
        scenario = parse(case.data, case.source)
        result = run_scenario(scenario, Path(rrd) if rrd else None, on_prepared=read_back)
    except BaseException as exc:  # a case's failure belongs in its row, sys.exit in a worker too
        if from_a_signal(exc) or isinstance(exc, raises):
            raise
        return error_row(case, applied, exc, time.perf_counter() - wall0)
    return result_row(case, applied, result, result.wall_s)


def error_row(case: Case, applied: dict, exc: BaseException, wall_s: float) -> dict:
    """The row of a case that raised `exc` (not a stop of its run: a build, a read-back, a trace
    that failed): its error names the exception and where it was raised."""
    last = traceback.extract_tb(exc.__traceback__)[-1]
    return case_row(case, applied, "error", False,
                    error_line(f"{described(exc)} ({Path(last.filename).name}:{last.lineno})"), wall_s)


def result_row(case: Case, applied: dict, result, wall_s: float) -> dict:
    """The row of a case whose run gave `result` (testbed.run_core.result.RunResult)."""
    from testbed.accuracy.guard import CHECK_NAMES as GUARD_CHECKS

    checks = {f"check:{c['name']}": "pass" if c["passed"] else "FAIL" for c in result.checks}
    for name in GUARD_CHECKS:  # every row has the guard's columns, as the table does (empty: not judged)
        checks.setdefault(f"check:{name}", "")
    return case_row(case, applied, result.status, result.passed, result.error or "", wall_s,
                    result.metrics | checks, failure_cause(result.status, result.error or "", result.checks))


def run_together(cases: list[Case], rrds: list[str | None]) -> list[dict]:
    """The rows of `cases` (a batch: testbed.campaign.batches), their traces to `rrds` (a path or
    None each), in that order. One case runs alone (`run_case`); several are stepped in lockstep
    (testbed.batch.lockstep.Batch), each world's row its own, as its single run's to the batch's
    round-off (docs/campaigns.md "Batches"). A case whose build or read-back fails has its error
    row and leaves the batch before the first step; a failure of the batch itself (not one of
    its worlds' stops: a trace that cannot be written) runs each of its cases alone."""
    from testbed.batch.lockstep import Batch
    from testbed.campaign.applied_values import applied_values, check_applied
    from testbed.exit_guard import os_exit_raises
    from testbed.run_core.in_progress import one_blas_thread
    from testbed.run_core.plan import prepare
    from testbed.scenario.loading import parse

    if len(cases) == 1:
        return [run_case(cases[0], rrds[0])]
    wall0 = time.perf_counter()
    rows: dict[int, dict] = {}
    worlds = []  # (position, case, applied, plan, rrd) of the cases built
    with one_blas_thread(), os_exit_raises():
        for position, (case, rrd) in enumerate(zip(cases, rrds)):
            applied: dict = {}
            try:
                scenario = parse(case.data, case.source)
                plan = prepare(scenario)
                applied.update(applied_values(case.values, scenario, plan.plant, plan.pipeline.stages()))
                check_applied(case.values, applied)
            except BaseException as exc:  # as in run_case: its row, the others go on
                if from_a_signal(exc):
                    raise
                rows[position] = error_row(case, applied, exc, time.perf_counter() - wall0)
                continue
            worlds.append((position, case, applied, plan, Path(rrd) if rrd else None))
        if worlds:
            try:
                with Batch([w[3] for w in worlds], [w[4] for w in worlds]) as batch:
                    batch.advance(batch.timing.n_ticks)
                    results = batch.finish()
            except BaseException as exc:
                if from_a_signal(exc):
                    raise
                return [rows.get(position) or run_case(case, rrd)
                        for position, (case, rrd) in enumerate(zip(cases, rrds))]
            share = (time.perf_counter() - wall0) / len(cases)
            for (position, case, applied, _, _), result in zip(worlds, results):
                rows[position] = result_row(case, applied, result, share)
    return [rows[position] for position in range(len(cases))]


def died_row(case: Case, reason: str) -> dict:
    """The row of a case that gave no result (testbed.campaign.dispatch.CaseLost: its worker died, or it ran too long)."""
    return case_row(case, {}, "error", False, reason)


def run_cases(cases: list[Case], workers: int | None = None, rrd_dir: Path | None = None,
              progress: Callable[[int, int, int], None] | None = None, scheduler: str | None = None,
              on_row: Callable[[dict], None] | None = None, engine=None,
              case_timeout_s: float | None = None, batch_size: int | None = None) -> list[dict]:
    """Rows for `cases`, in case order, run on `engine` (testbed.campaign.engine.Engine, already
    started), else on one started here: a local cluster of `workers` processes, or the Dask
    scheduler at `scheduler`; `on_row(row)` and `progress(done, total, failed)` after each case,
    as its batch finishes. The cases run in batches (testbed.campaign.batches; at most
    `batch_size` cases, 1: each alone). A case may run `case_timeout_s`, else the bound its build
    gave (prepared["timeout_s"], testbed.campaign.case_timeout), else without a bound; a batch
    the sum of its cases' bounds. A batch that runs past its bound, or whose worker dies, is
    not retried: each of its cases runs again alone, with its own bound and retries
    (testbed.campaign.dispatch), so that only the case at fault gets the error row."""
    from testbed.campaign.batches import batch_timeout_s, batches
    from testbed.campaign.dispatch import CaseLost
    from testbed.campaign.engine import Engine

    if engine is None:
        with Engine(workers, scheduler) as started:
            return run_cases(cases, rrd_dir=rrd_dir, progress=progress, on_row=on_row, engine=started,
                             case_timeout_s=case_timeout_s, batch_size=batch_size)
    # absolute, made once here: a case whose stage changes its worker's cwd moves no other case's trace
    folder = Path(rrd_dir).absolute() if rrd_dir else None

    def task(batch: list[Case]) -> tuple:
        return batch, [str(case_trace(folder, case.index)) if folder else None for case in batch]

    def timeout_s(args) -> float | None:
        return batch_timeout_s([case_timeout_s or (case.prepared or {}).get("timeout_s") for case in args[0]])

    def name(args) -> str:
        batch = args[0]
        return f"case{batch[0].index}" if len(batch) == 1 else f"cases{batch[0].index}+{len(batch) - 1}"

    def alone(args) -> list[tuple]:
        return [task([case]) for case in args[0]] if len(args[0]) > 1 else []

    tasks = [task(batch) for batch in batches(cases, max(1, engine.worker_count), batch_size)]
    rows: dict[int, dict] = {}
    for (batch, _), outcome in engine.results(run_together, tasks, name, timeout_s, alone):
        lost = isinstance(outcome, CaseLost)
        for case, row in zip(batch, [died_row(case, outcome.reason) for case in batch] if lost else outcome):
            rows[case.index] = row
            if on_row:
                on_row(row)
            if progress:
                progress(len(rows), len(cases), sum(not r["passed"] for r in rows.values()))
    return [rows[c.index] for c in cases]
