"""A campaign's summary (testbed.campaign.stats `summary`) as Markdown tables: the first tab of
DIR/summary/summary.rrd, before its plots."""

from __future__ import annotations

import re

from testbed.recording.markdown_table import markdown_table
from testbed.scenario.schema import unit_of

SPREAD = ("mean", "sigma", "p5", "p50", "p95", "max")


def summary_markdown(summary: dict) -> str:
    """Pass rate (overall and by grid value or choice), each metric's spread with its unit, and
    the worst cases with the command that reruns each."""
    statuses = ", ".join(f"{n} {status}" for status, n in summary["status"].items())
    lines = [f"# {summary['scenario']}", "", f"{summary['cases']} cases: {statuses}", ""]
    rate = summary["pass_rate"]
    if rate["cases"]:
        lines += [f"**pass rate {_rate(rate)}** ({rate['method']})", ""]
    for column, by_value in summary.get("pass_rate_by", {}).items():
        lines += markdown_table([column, "passed", "pass rate", f"{_confidence(by_value)} interval"],
                                [[value, f"{r['passed']}/{r['cases']}", f"{r['rate']:.1%}",
                                  f"[{r['low']:.1%}, {r['high']:.1%}]"] for value, r in by_value.items()]) + [""]
    lines += markdown_table(["metric", "unit", *SPREAD, "not finite"],
                            [[name, unit_text(name), *(f"{spread[k]:.4g}" for k in SPREAD), spread["not_finite"]]
                             if spread["cases"] else [name, unit_text(name), *["-"] * len(SPREAD), spread["not_finite"]]
                             for name, spread in summary["metrics"].items()]) + [""]
    points = summary.get("by_grid_point") or []
    if points:
        lines += ["## checked metrics by grid point (mean over its cases)", ""]
        lines += markdown_table([*points[0]["values"], "cases", *(f"{m} [{unit_text(m)}]" for m in points[0]["means"])],
                                [[*p["values"].values(), p["cases"], *("-" if v is None else f"{v:.4g}"
                                                                       for v in p["means"].values())]
                                 for p in points]) + [""]
    if summary["worst"]:
        lines += ["## worst cases", ""]
        lines += markdown_table(["case", "status", "why", "rerun"],
                                [[w["case"], w["status"] + ("" if w["passed"] else ", failed"), w["why"],
                                  f"`{w['rerun']}`"] for w in summary["worst"]])
    return "\n".join(lines)


def unit_text(column: str) -> str:
    """The unit of a table column, from its key's name (an element [i] of a vector, a dispersion
    `path:key`): "deg/s", or "1" for a dimensionless one."""
    return unit_of(re.sub(r"\[\d+\]$", "", column)) or "1"


def _rate(rate: dict) -> str:
    return (f"{rate['passed']}/{rate['cases']} = {rate['rate']:.1%}, {rate['confidence']:.0%} interval "
            f"[{rate['low']:.1%}, {rate['high']:.1%}]")


def _confidence(by_value: dict) -> str:
    return next((f"{r['confidence']:.0%}" for r in by_value.values() if r["cases"]), "")
