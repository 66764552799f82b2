"""A campaign's summary trace, DIR/summary/summary.rrd: it opens on the summary (pass rate, spreads,
worst cases) as tables; a tab of a histogram of every metric, and one tab per metric with its
scatter plot against every dispersed parameter, so a sensitivity shows at a glance.

Rerun plots scalars against a timeline, not against another scalar, so each scatter plot puts
the parameter on a sequence timeline of its kind, TIMELINE: x = round(value / 10^(k - 3)), k
chosen per parameter so that |value| / 10^k < 10 (four significant digits; the view's title
gives the unit and 10^(k - 3)), and a text parameter (a choice) by the index of its value (the
title lists them). The time panel opens on that timeline. Passed cases are green points,
failed ones red. Every view's title gives the units of its axes.

Entities: `histogram/<metric>` (BarChart: counts, bin centres as abscissa, bin widths),
`scatter/<metric>/<parameter>/passed|failed` (Scalars with SeriesPoints), `summary` (markdown).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from testbed.recording.rerun_sdk import rr
from testbed.recording.rerun_sdk import rrb

from testbed.campaign.summary_markdown import summary_markdown, unit_text
from testbed.recording.trace import recording_to

TIMELINE = "parameter (scale in each plot's title)"
GREEN, RED = [40, 170, 70], [220, 50, 50]
DIGITS = 4  # significant digits of a scatter plot's x
ROUND_OFF_ULPS = 8  # values this close are one value to the histogram (a sum in another order)
MAX_BINS = 40


def histogram(values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(counts, bin centres, bin widths) of the finite values: numpy's 'auto' bins, at most
    MAX_BINS and each at least ROUND_OFF_ULPS / 2 wide. Values within ROUND_OFF_ULPS of each other
    (all equal, or apart by round-off) are one bar at their midpoint, a tenth of its magnitude wide
    (1 for zero), so that the axis is centred on it."""
    low, high = float(values.min()), float(values.max())
    floor = ROUND_OFF_ULPS * float(np.spacing(max(abs(low), abs(high))))
    if high - low <= floor:
        centre = low + (high - low) / 2
        return np.array([len(values)]), np.array([centre]), np.array([0.1 * abs(centre) or 1.0])
    # the bin count of the values mapped onto [0, 1] (numpy's estimators do not depend on scale or
    # offset), so that a span of a few ulps cannot make numpy's own edges collide
    auto = len(np.histogram_bin_edges((values - low) / (high - low), "auto")) - 1
    bins = max(1, min(auto, MAX_BINS, int((high - low) / (floor / 2))))
    counts, edges = np.histogram(values, bins=bins, range=(low, high))
    return counts, (edges[:-1] + edges[1:]) / 2, np.diff(edges)


def axis_scale(values) -> int:
    """k with max |values| / 10^k in [1, 10) (0 for all zeros): the x of a scatter plot."""
    peak = max((abs(v) for v in values), default=0.0)
    return int(math.floor(math.log10(peak))) if peak > 0 else 0


def parameter_axis(parameter: str, cells: list) -> tuple[list, str]:
    """(x per case, its label: the parameter, unit and scale) of a parameter column: numbers as
    integers value / 10^(k - DIGITS + 1) (integers as they are), text by the index of its value
    in order of appearance (listed in the label)."""
    if all(isinstance(c, (int, float)) and not isinstance(c, bool) or c is None for c in cells):
        finite = [c for c in cells if c is not None and math.isfinite(c)]
        shift = axis_scale(finite) - DIGITS + 1 if any(c != round(c) for c in finite) else 0
        scale = f" x 1e{shift}" if shift else ""
        x = [None if c is None or not math.isfinite(c) else round(c / 10.0**shift) for c in cells]
        return x, f"{parameter} [{unit_text(parameter)}{scale}]"
    labels = list(dict.fromkeys(str(c) for c in cells))
    return [labels.index(str(c)) for c in cells], f"{parameter} (" + ", ".join(f"{i} = {v}" for i, v in enumerate(labels)) + ")"


def write_summary_rrd(path: Path, rows: list[dict], metric_names: list[str], parameters: list[str],
                      summary: dict) -> Path:
    """Write the summary trace of a campaign's `rows` (see module doc) atomically to `path`."""

    histograms, tabs = [], []
    with recording_to(path) as rec:
        for metric in metric_names:
            y = np.array([_number(r.get(metric)) for r in rows], float)
            finite = np.isfinite(y)
            if not finite.any():
                continue
            counts, centres, widths = histogram(y[finite])
            entity = f"histogram/{_part(metric)}"
            rec.log(entity, rr.BarChart(counts, abscissa=centres, widths=widths), static=True)
            histograms.append(rrb.BarChartView(origin=entity, name=f"{metric} [{unit_text(metric)}]: cases a bin",
                                               plot_legend=rrb.PlotLegend(visible=False)))  # the title says it
            views = []
            for parameter in parameters:
                x, label = parameter_axis(parameter, [r.get(parameter) for r in rows])
                keep = [i for i in range(len(rows)) if finite[i] and x[i] is not None]
                if not keep:
                    continue
                origin = f"scatter/{_part(metric)}/{_part(parameter)}"
                for outcome, color in (("passed", GREEN), ("failed", RED)):
                    chosen = [i for i in keep if bool(rows[i]["passed"]) == (outcome == "passed")]
                    if chosen:
                        rec.log(f"{origin}/{outcome}", rr.SeriesPoints(colors=[color], names=[outcome],
                                                                       marker_sizes=[3.0]), static=True)
                        rec.send_columns(f"{origin}/{outcome}",
                                         indexes=[rr.TimeColumn(TIMELINE, sequence=[x[i] for i in chosen])],
                                         columns=rr.Scalars.columns(scalars=y[chosen]))
                low, high = min(x[i] for i in keep), max(x[i] for i in keep)
                pad = max(1, round(0.05 * (high - low)))
                axis = rrb.TimeAxis(view_range=rrb.TimeRange(start=rrb.TimeRangeBoundary.absolute(seq=low - pad),
                                                             end=rrb.TimeRangeBoundary.absolute(seq=high + pad)))
                views.append(rrb.TimeSeriesView(origin=origin, name=f"{metric} [{unit_text(metric)}] vs {label}", axis_x=axis,
                                                plot_legend=rrb.PlotLegend(rrb.Corner2D.RightTop)))
            if views:
                tabs.append(rrb.Grid(*views, grid_columns=2, name=f"{metric} vs parameters"))
        rec.log("summary", rr.TextDocument(summary_markdown(summary), media_type="text/markdown"), static=True)
        pictures = [rrb.Grid(*histograms, grid_columns=2, name="histograms")] if histograms else []
        rec.send_blueprint(rrb.Blueprint(
            rrb.Tabs(rrb.TextDocumentView(origin="/summary", name="summary"), *pictures, *tabs, active_tab="summary"),
            rrb.TimePanel(timeline=TIMELINE, state="collapsed"),
            rrb.BlueprintPanel(state="collapsed"), rrb.SelectionPanel(state="collapsed")))
    return Path(path)


def _number(value) -> float:
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else math.nan


def _part(name: str) -> str:
    """A table column's name as one entity path part."""
    return rr.escape_entity_path_part(name)
