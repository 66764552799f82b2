"""A campaign's summary trace, DIR/summary/summary.rrd: it opens on a histogram of every metric, and
has one tab per metric with its scatter plot against every dispersed parameter, so a
sensitivity shows at a glance; the summary (pass rate, spreads, worst cases) beside them.

Rerun plots scalars against a timeline, not against another scalar, so each scatter plot puts
the parameter on a timeline of its own kind, `dispersed value` (a duration, which Rerun labels
in seconds): x = value / 10^k with k chosen per parameter so that |x| < 10 (the view's title
gives 10^k), and a text parameter (a choice) by the index of its value (the title lists them).
The time panel opens on that timeline. Passed cases are green points, failed ones red.

Entities: `histogram/<metric>` (BarChart: counts, bin centres as abscissa, bin widths),
`scatter/<metric>/<parameter>/passed|failed` (Scalars with SeriesPoints), `summary` (text).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from testbed.recording.trace import recording_to

TIMELINE = "dispersed value"
GREEN, RED = [40, 170, 70], [220, 50, 50]


def histogram(values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(counts, bin centres, bin widths) of the finite values: numpy's 'auto' bins, at most 40."""
    counts, edges = np.histogram(values, bins=min(len(np.histogram_bin_edges(values, "auto")) - 1, 40) or 1)
    return counts, (edges[:-1] + edges[1:]) / 2, np.diff(edges)


def axis_scale(values) -> int:
    """k with max |values| / 10^k in [1, 10) (0 for all zeros): the x of a scatter plot."""
    peak = max((abs(v) for v in values), default=0.0)
    return int(math.floor(math.log10(peak))) if peak > 0 else 0


def parameter_axis(cells: list) -> tuple[list, str]:
    """(x per case, label suffix) of a parameter column: numbers scaled by 10^-k, text by the
    index of its value in order of appearance."""
    if all(isinstance(c, (int, float)) and not isinstance(c, bool) or c is None for c in cells):
        k = axis_scale([c for c in cells if c is not None and math.isfinite(c)])
        return [None if c is None else c / 10.0**k for c in cells], (f" [x 1e{k}]" if k else "")
    labels = list(dict.fromkeys(str(c) for c in cells))
    return [labels.index(str(c)) for c in cells], " [" + ", ".join(f"{i} = {v}" for i, v in enumerate(labels)) + "]"


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
            histograms.append(rrb.BarChartView(origin=entity, name=metric))
            views = []
            for parameter in parameters:
                x, suffix = parameter_axis([r.get(parameter) for r in rows])
                keep = [i for i in range(len(rows)) if finite[i] and x[i] is not None and math.isfinite(x[i])]
                if not keep:
                    continue
                origin = f"scatter/{_part(metric)}/{_part(parameter)}"
                for outcome, color in (("passed", GREEN), ("failed", RED)):
                    chosen = [i for i in keep if bool(rows[i]["passed"]) == (outcome == "passed")]
                    if chosen:
                        rec.log(f"{origin}/{outcome}", rr.SeriesPoints(colors=[color], names=[outcome],
                                                                       marker_sizes=[3.0]), static=True)
                        rec.send_columns(f"{origin}/{outcome}",
                                         indexes=[rr.TimeColumn(TIMELINE, duration=[x[i] for i in chosen])],
                                         columns=rr.Scalars.columns(scalars=y[chosen]))
                low, high = min(x[i] for i in keep), max(x[i] for i in keep)
                pad = 0.05 * (high - low) or 0.5
                axis = rrb.TimeAxis(view_range=rrb.TimeRange(
                    start=rrb.TimeRangeBoundary.absolute(seconds=low - pad),
                    end=rrb.TimeRangeBoundary.absolute(seconds=high + pad)))
                views.append(rrb.TimeSeriesView(origin=origin, name=f"{metric} vs {parameter}{suffix}", axis_x=axis,
                                                plot_legend=rrb.PlotLegend(rrb.Corner2D.RightTop)))
            if views:
                tabs.append(rrb.Grid(*views, name=f"{metric} vs parameters"))
        rec.log("summary", rr.TextDocument(json.dumps(summary, indent=1), media_type="text/plain"), static=True)
        first = rrb.Grid(*histograms, name="histograms") if histograms else rrb.TextDocumentView(origin="/summary")
        rec.send_blueprint(rrb.Blueprint(
            rrb.Horizontal(rrb.Tabs(first, *tabs), rrb.TextDocumentView(origin="/summary", name="summary"),
                           column_shares=[4, 1]),
            rrb.TimePanel(timeline=TIMELINE, state="collapsed"),
            rrb.BlueprintPanel(state="collapsed"), rrb.SelectionPanel(state="collapsed")))
    return Path(path)


def _number(value) -> float:
    return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else math.nan


def _part(name: str) -> str:
    """A table column's name as one entity path part."""
    return rr.escape_entity_path_part(name)
