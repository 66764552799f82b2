"""Run the cases of a sweep in parallel processes and tabulate them (one CSV row per case).

Each case runs in a worker process (concurrent.futures with the spawn start method, so it
works the same on every platform and never inherits a half-initialised MuJoCo); one worker
runs the cases in this process. A case that raises, diverges or fails a check is reported
in its row and never stops the others; a worker process that dies takes only the cases it
had in flight with it (they are retried once in a fresh pool, then reported).
"""

from __future__ import annotations

import csv
import multiprocessing
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Callable

from testbed.sweep import Case


def run_case(case: Case, rrd: str | None) -> dict:
    """Run one case; everything that happens is returned as a row (never raised)."""
    from testbed.runner import run_scenario
    from testbed.scenario import parse

    row = {"case": case.index, **case.values}
    wall0 = time.perf_counter()
    try:
        result = run_scenario(parse(case.data, case.source), Path(rrd) if rrd else None)
    except Exception as exc:  # noqa: BLE001  (a case's failure belongs in its row)
        last = traceback.extract_tb(exc.__traceback__)[-1]
        return row | {"status": "error", "passed": False, "wall_s": time.perf_counter() - wall0,
                      "error": f"{type(exc).__name__}: {exc} ({Path(last.filename).name}:{last.lineno})"}
    row |= {"status": result.status, "passed": result.passed, "wall_s": result.wall_s, "error": result.error or ""}
    row |= result.metrics
    row |= {f"check:{c['name']}": "pass" if c["passed"] else "FAIL" for c in result.checks}
    return row


def run_cases(cases: list[Case], workers: int, rrd_dir: Path | None = None,
              progress: Callable[[int, int, int], None] | None = None) -> list[dict]:
    """Rows for `cases`, in case order; `progress(done, total, failed)` after each case."""
    rrd = {c.index: str(rrd_dir / f"case{c.index:04d}.rrd") if rrd_dir else None for c in cases}
    rows: dict[int, dict] = {}

    def finished(row):
        rows[row["case"]] = row
        if progress:
            progress(len(rows), len(cases), sum(not r["passed"] for r in rows.values()))

    if workers == 1:
        for case in cases:
            finished(run_case(case, rrd[case.index]))
    else:
        pending, tries = list(cases), {c.index: 0 for c in cases}
        while pending:
            context = multiprocessing.get_context("spawn")
            with ProcessPoolExecutor(max_workers=min(workers, len(pending)), mp_context=context) as pool:
                futures = {pool.submit(run_case, case, rrd[case.index]): case for case in pending}
                pending = []
                for future in as_completed(futures):
                    case = futures[future]
                    try:
                        finished(future.result())
                    except BrokenProcessPool:
                        tries[case.index] += 1
                        if tries[case.index] < 2:
                            pending.append(case)
                        else:
                            finished({"case": case.index, **case.values, "status": "error", "passed": False,
                                      "error": "the worker process died running this case"})
    return [rows[c.index] for c in cases]


def columns(rows: list[dict], fields: list[str]) -> list[str]:
    """case, the swept fields, status columns, then metrics and checks in first-seen order."""
    head = ["case", *fields, "status", "passed", "error", "wall_s"]
    rest: dict[str, None] = {}
    for row in rows:
        rest.update({k: None for k in row if k not in head and not k.startswith("check:")})
    checks: dict[str, None] = {}
    for row in rows:
        checks.update({k: None for k in row if k.startswith("check:")})
    return head + list(rest) + list(checks)


def write_csv(path: Path, rows: list[dict], fields: list[str]) -> Path:
    """One row per case; floats written with repr (round-trip exact), missing cells empty."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns(rows, fields), restval="")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: repr(v) if isinstance(v, float) else v for k, v in row.items()})
    return path
