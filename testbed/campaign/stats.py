"""What a campaign's table says: the pass rate with its confidence interval, each metric's
spread, and the worst cases with the command that reruns each.

- pass rate: passed / cases with the exact (Clopper-Pearson) 95 % interval of a binomial
  proportion (scipy.stats.binomtest(...).proportion_ci(method="exact")): it covers the true
  rate at least 95 % of the time, also at 0 or all passes (200 of 200 gives [0.982, 1]); and
  the same for the cases of each value of a grid field or a choice;
- per metric, over the cases where it is finite: mean, sigma (n - 1), p5, p50, p95 (numpy's
  linear interpolation) and max, with how many cases gave no finite value;
- worst cases: errors and divergences first, then failed checks, then the others; within each,
  by the smallest check margin, (limit - value) / |limit| for a max and (value - limit) / |limit|
  for a min (|limit| = 0 counts as 1; a non-finite value is the worst margin), over the checks
  whose margin differs between cases (a count held at its limit of 0 in every case tells none
  apart) and any the case fails.
"""

from __future__ import annotations

import math
import shlex

import numpy as np
from scipy import stats

from testbed.scenario.loading import CheckLimit

CONFIDENCE = 0.95
WORST = 5


def pass_rate(passed: int, cases: int) -> dict:
    """passed / cases and its exact (Clopper-Pearson) CONFIDENCE interval."""
    if cases == 0:
        return {"passed": 0, "cases": 0, "rate": None, "low": None, "high": None}
    interval = stats.binomtest(passed, cases).proportion_ci(CONFIDENCE, method="exact")
    return {"passed": passed, "cases": cases, "rate": passed / cases, "low": float(interval.low),
            "high": float(interval.high), "confidence": CONFIDENCE, "method": "Clopper-Pearson (exact)"}


def metric_spread(values) -> dict:
    """Mean, sigma, p5, p50, p95 and max of the finite values, and how many were not finite."""
    x = np.asarray([v for v in values if v is not None], float)
    finite = x[np.isfinite(x)]
    out = {"cases": int(len(finite)), "not_finite": int(len(x) - len(finite))}
    if len(finite):
        p5, p50, p95 = np.percentile(finite, [5, 50, 95])
        out |= {"mean": float(finite.mean()), "sigma": float(finite.std(ddof=1)) if len(finite) > 1 else 0.0,
                "p5": float(p5), "p50": float(p50), "p95": float(p95), "max": float(finite.max())}
    return out


def check_margin(value, limit: dict) -> float:
    """How far `value` is inside a check's {max: X} / {min: X} (negative: outside), per |limit|."""
    if value is None or not math.isfinite(value):
        return -math.inf
    margins = [(bound - value if key == "max" else value - bound) / (abs(bound) or 1.0)
               for key, bound in limit.items() if key in ("max", "min") and bound is not None]
    return min(margins, default=math.inf)


def worst_cases(rows: list[dict], limits: dict[int, dict], rerun) -> list[dict]:
    """The WORST worst rows (module doc): case, status, margin, the check nearest its limit or
    the error, and `rerun(case)`, the command that reruns it. limits: case -> {check: {max|min}}."""
    margins = {row["case"]: {name: check_margin(_number(row.get(name)), limit)
                             for name, limit in limits[row["case"]].items()} for row in rows}
    telling = {name for case in margins.values() for name in case
               if len({m[name] for m in margins.values() if name in m}) > 1}
    ranked = []
    for row in rows:
        told = {name: m for name, m in margins[row["case"]].items() if name in telling or m < 0}
        name, margin = min(told.items(), key=lambda item: item[1], default=("", math.inf))
        severity = 0 if row["status"] != "ok" else 1 if not row["passed"] else 2
        why = row["error"] or (f"{name} = {row.get(name)!r} ({'fails' if margin < 0 else 'passes'} "
                               f"{CheckLimit(**limits[row['case']][name]).text})" if name else "")
        ranked.append(((severity, margin, row["case"]), {
            "case": row["case"], "status": row["status"], "passed": row["passed"],
            "margin": margin if math.isfinite(margin) else None, "why": why, "rerun": rerun(row["case"])}))
    return [entry for _, entry in sorted(ranked, key=lambda item: item[0])[:WORST]]


def pass_rate_by(rows: list[dict], column: str) -> dict[str, dict]:
    """value -> pass rate of the cases with that value in `column` (a grid field or a choice)."""
    groups: dict[str, list[bool]] = {}
    for row in rows:
        groups.setdefault(str(row.get(column)), []).append(bool(row["passed"]))
    return {value: pass_rate(sum(passed), len(passed)) for value, passed in groups.items()}


def by_grid_point(rows: list[dict], grid: list[str], metrics: list[str]) -> list[dict]:
    """One entry per point of the grid (columns `grid`), in case order: its values, its cases, and
    each of `metrics` averaged over its cases where finite (None where none is): how a checked
    figure moves with the swept parameters."""
    points: dict[tuple, list[dict]] = {}
    for row in rows:
        points.setdefault(tuple(str(row.get(c)) for c in grid), []).append(row)
    table = []
    for key, members in points.items():
        means = {}
        for m in metrics:
            finite = [v for v in (_number(r.get(m)) for r in members) if v is not None and math.isfinite(v)]
            means[m] = sum(finite) / len(finite) if finite else None
        table.append({"values": dict(zip(grid, key)), "cases": len(members), "means": means})
    return table


def summary(name: str, rows: list[dict], metric_names: list[str], limits: dict[int, dict], rerun,
            groups=(), grid=()) -> dict:
    """summary.json of a finished campaign (module doc); `groups`: the columns (grid fields and
    choices) whose every value gets a pass rate of its own; `grid`: the grid's columns, whose
    every point gets the mean of each checked metric (`by_grid_point`)."""
    statuses: dict[str, int] = {}
    for row in rows:
        statuses[row["status"]] = statuses.get(row["status"], 0) + 1
    return {"scenario": name, "cases": len(rows), "status": statuses,
            "pass_rate": pass_rate(sum(bool(r["passed"]) for r in rows), len(rows)),
            "pass_rate_by": {column: pass_rate_by(rows, column) for column in groups},
            "metrics": {m: metric_spread(_number(r.get(m)) for r in rows) for m in metric_names},
            "worst": worst_cases(rows, limits, rerun),
            "by_grid_point": by_grid_point(rows, list(grid), list(dict.fromkeys(
                m for checks in limits.values() for m in checks if m in metric_names))) if grid else []}


def rerun_command(source: str, overrides: list[str], out: str):
    """case -> the command line that reruns it alone and writes its trace."""
    sets = "".join(f" --set {shlex.quote(s)}" for s in overrides)
    return lambda case: f"testbed sweep {shlex.quote(source)} --case {case}{sets} --out {shlex.quote(out)}"


def report(summary_: dict) -> list[str]:
    """The terminal lines of a summary."""
    rate = summary_["pass_rate"]
    lines = []
    if rate["cases"]:
        lines.append(f"pass rate {_rate_text(rate)} ({rate['method']})")
        # how the cases ended: the failures that stopped early by their kind (a rerun names each cause)
        lines.append("status: " + ", ".join(f"{status} {count}" for status, count in summary_["status"].items()))
    for column, by_value in summary_.get("pass_rate_by", {}).items():
        for value, rate in by_value.items():
            lines.append(f"  {column} = {value}: {_rate_text(rate)}")
    lines.append(f"{'metric':36s} {'mean':>11s} {'sigma':>11s} {'p5':>11s} {'p50':>11s} {'p95':>11s} {'max':>11s}")
    for name, spread in summary_["metrics"].items():
        if spread["cases"]:
            cells = " ".join(f"{spread[k]:11.4g}" for k in ("mean", "sigma", "p5", "p50", "p95", "max"))
            extra = f"  ({spread['not_finite']} not finite)" if spread["not_finite"] else ""
            lines.append(f"{name:36s} {cells}{extra}")
        else:
            lines.append(f"{name:36s} {'no finite value':>11s}")
    points = summary_.get("by_grid_point") or []
    if points:
        lines.append("checked metrics by grid point (mean over its cases):")
        columns = [*points[0]["values"], *points[0]["means"]]
        widths = [max(12, len(c)) for c in columns]
        lines.append("  " + " ".join(f"{c:>{w}s}" for c, w in zip(columns, widths)))
        for point in points:
            cells = [*point["values"].values(), *("-" if v is None else f"{v:.4g}" for v in point["means"].values())]
            lines.append("  " + " ".join(f"{c:>{w}s}" for c, w in zip(cells, widths)))
    lines.append("worst cases:")
    for entry in summary_["worst"]:
        lines.append(f"  case {entry['case']}: {entry['status']}{'' if entry['passed'] else ', failed'}: {entry['why']}")
        lines.append(f"    {entry['rerun']}")
    return lines


def _rate_text(rate: dict) -> str:
    return (f"{rate['passed']}/{rate['cases']} = {rate['rate']:.1%}, {rate['confidence']:.0%} interval "
            f"[{rate['low']:.1%}, {rate['high']:.1%}]")


def _number(value):
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else None
