"""The pictures of a campaign's summary.rrd (issue 39): histogram ranges for constant and
round-off-apart metrics, units and scales in every title, the summary as Markdown tables."""

from __future__ import annotations

import math

import numpy as np
import pytest

from testbed.campaign.plots import histogram, parameter_axis, write_summary_rrd
from testbed.campaign.stats import summary
from testbed.campaign.summary_markdown import unit_text


def test_values_one_ulp_apart_make_one_bar_at_their_value():
    """np.histogram_bin_edges(..., "auto") raises for [1, 1 + 1 ulp]: the values are one value
    to within round-off, one bar centred on it, a tenth of it wide."""
    values = np.array([1.0, np.nextafter(1.0, 2.0), 1.0])
    counts, centres, widths = histogram(values)
    assert counts.tolist() == [3]
    assert centres[0] == pytest.approx(1.0, abs=1e-15) and widths[0] == pytest.approx(0.1)


@pytest.mark.parametrize("value, width", [(1.0, 0.1), (-250.0, 25.0), (0.0, 1.0), (3e-12, 3e-13)])
def test_a_constant_metric_is_one_bar_centred_on_it(value, width):
    counts, centres, widths = histogram(np.full(7, value))
    assert counts.tolist() == [7] and centres[0] == value and widths[0] == pytest.approx(width)
    assert centres[0] - widths[0] / 2 < value < centres[0] + widths[0] / 2


def test_a_few_ulps_apart_beyond_round_off_get_increasing_edges_and_every_value_counted():
    """A span of 40 ulps: more than round-off, too few for numpy's own bin count."""
    values = 1.0 + np.arange(41) * np.spacing(1.0)
    counts, centres, widths = histogram(values)
    assert counts.sum() == 41 and np.all(widths > 0) and np.all(np.diff(centres) > 0)


def test_ordinary_values_get_numpys_auto_bins():
    """Against numpy's 'auto' edges of the same values (a second method), where it does not raise."""
    values = np.random.default_rng(5).normal(3.0, 0.2, 200)
    edges = np.histogram_bin_edges(values, "auto")
    counts, centres, widths = histogram(values)
    assert np.array_equal(counts, np.histogram(values, edges)[0])
    assert np.allclose(centres, (edges[1:] + edges[:-1]) / 2, rtol=1e-12) and np.allclose(widths, np.diff(edges))


def test_parameter_axes_carry_unit_and_scale_and_are_integers():
    x, label = parameter_axis("initial.omega_deg_s[1]", [-0.006704694, 0.0123, None])
    assert label == "initial.omega_deg_s[1] [deg/s x 1e-5]" and x == [-670, 1230, None]
    x, label = parameter_axis("pipeline.gain_k", [1, 2, 30])
    assert label == "pipeline.gain_k [1]" and x == [1, 2, 30]
    x, label = parameter_axis("sim.integrator", ["RK4", "Euler", "RK4"])
    assert label == "sim.integrator (0 = RK4, 1 = Euler)" and x == [0, 1, 0]
    assert unit_text("final_omega_rad_s") == "rad/s" and unit_text("torque_error_rel") == "1"


def test_summary_rrd_is_written_for_round_off_apart_values_with_a_markdown_summary(tmp_path):
    """The finding of issue 37: a metric 1 and 1 + 1 ulp no longer stops summary.rrd; its pane is
    Markdown tables (one row per metric with its unit), not JSON."""
    from rerun.chunk import RrdReader

    rows = [{"case": i, "status": "ok", "passed": i != 2, "error": "", "peak_dipole_use": v,
             "final_omega_rad_s": 0.01 * i, "initial.omega_deg_s[0]": 0.1 * i}
            for i, v in enumerate([1.0, 1.0000000000000002, 1.0])]
    limits = {i: {"peak_dipole_use": {"max": 1.0, "min": None}} for i in range(3)}
    result = summary("c", rows, ["peak_dipole_use", "final_omega_rad_s"], limits, lambda case: f"rerun {case}", [])
    path = write_summary_rrd(tmp_path / "summary.rrd", rows, ["peak_dipole_use", "final_omega_rad_s"],
                             ["initial.omega_deg_s[0]"], result)
    texts = {}
    for chunk in RrdReader(str(path)).stream():
        batch = chunk.to_record_batch()
        if "TextDocument:text" in batch.schema.names:
            texts[str(chunk.entity_path)] = (batch.column("TextDocument:text")[0].as_py()[0],
                                             batch.column("TextDocument:media_type")[0].as_py()[0])
    text, media = texts["/summary"]
    assert media == "text/markdown" and not text.lstrip().startswith("{")
    assert "| final_omega_rad_s | rad/s | 0.01 | 0.01 | 0.001 | 0.01 | 0.019 | 0.02 | 0 |" in text
    assert "| 2 | ok, failed |" in text and "`rerun 2`" in text
    assert math.isclose(result["metrics"]["peak_dipole_use"]["max"], 1.0, rel_tol=1e-15)
