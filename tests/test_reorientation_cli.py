"""Issue 3 input handling and the `testbed envelope` command: bad input is one line, exit 2."""

from __future__ import annotations

import numpy as np
import pytest

from testbed.cli import main

SLEW = "pipeline.law"


@pytest.mark.parametrize("override, field, words", [
    ("pipeline.allocator.beta_rate_max_deg_s=0", "pipeline.allocator.beta_rate_max_deg_s", "> 0"),
    ("pipeline.allocator.beta_rate_max_deg_s=-5", "pipeline.allocator.beta_rate_max_deg_s", "> 0"),
    ("pipeline.allocator.options={rcond: 5}", "pipeline.allocator.options.rcond", "must be in"),
    ("model.alpha_deg=0", "model.alpha_deg", "> 0"),
    ("model.alpha_deg=90", "model.alpha_deg", "< 90"),
    ("model.alpha_deg=120", "model.alpha_deg", "< 90"),
    (f"{SLEW}.duration_s=0", f"{SLEW}.duration_s", "> 0"),
    (f"{SLEW}.duration_s=-3", f"{SLEW}.duration_s", "> 0"),
    (f"{SLEW}.axis=[0, 0, 0]", f"{SLEW}.axis", "zero vector"),
    (f"{SLEW}.axis=[1, 1, 0]", f"{SLEW}.axis", "unit vector"),
    (f"{SLEW}.axis=[1, 0]", f"{SLEW}.axis", "3 elements"),
    (f"{SLEW}.angle_deg=200", f"{SLEW}.angle_deg", "<= 180"),
    (f"{SLEW}.natural_frequency_rad_s=0", f"{SLEW}.natural_frequency_rad_s", "> 0"),
    ("pipeline.estimator.type=none", "pipeline.estimator.type", "quat"),
    ("pipeline.sensor.type=none", "pipeline.estimator.type", "measures quat"),
])
def test_bad_reorientation_input_exits_2_with_one_line(override, field, words, tmp_path, capsys):
    out = tmp_path / "x.rrd"
    assert main(["run", "reorient_minimax", "--set", override, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert err.startswith(f"error: {field}:") and words in err
    assert not out.exists()


@pytest.mark.parametrize("argv, field", [
    (["--alpha-deg", "0"], "--alpha-deg"),
    (["--alpha-deg", "90"], "--alpha-deg"),
    (["--alpha-deg", "-10"], "--alpha-deg"),
    (["--alpha-deg", "nan"], "--alpha-deg"),
    (["--alpha-deg", "45", "--h", "0"], "--h"),
    (["--alpha-deg", "45", "--points", "0"], "--points"),
    (["--h", "2"], "usage"),
])
def test_envelope_bad_input_exits_2(argv, field, tmp_path, capsys):
    out = tmp_path / "e.rrd"
    assert main(["envelope", *argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith(f"error: {field}")
    assert not out.exists()


def test_envelope_command_writes_the_surfaces_with_the_analytic_extents(tmp_path, capsys):
    from rerun.chunk import RrdReader

    alpha, h = 40.0, 2.0
    out = tmp_path / "e.rrd"
    assert main(["envelope", "--alpha-deg", str(alpha), "--h", str(h), "--points", "800", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    a = np.radians(alpha)
    for value in (4 * h * np.cos(a), 4 * h * np.sin(a), 4 * h):
        assert f"{value:.6g} N m s" in printed
    points = {}
    for chunk in RrdReader(str(out)).stream():
        batch = chunk.to_record_batch()
        if "Points3D:positions" in batch.schema.names:
            rows = [r for r in batch.column("Points3D:positions").to_pylist() if r]
            points[str(chunk.entity_path)] = np.array(rows[0])
    assert "/envelope/external" in points and len([e for e in points if "/internal/" in e]) == 7
    ext = points["/envelope/external"]
    # the envelope's support along x, y, z: never beyond 4h (cos a, sin a, 1), reached on the grid to ~1 %
    support = np.abs(ext).max(axis=0)
    bound = 4 * h * np.array([np.cos(a), np.sin(a), 1.0])
    assert np.all(support <= bound * (1 + 1e-9)) and np.all(support >= 0.99 * bound)
