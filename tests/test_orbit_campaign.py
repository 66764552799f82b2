"""Validation 5, a slice run for real: the first cases of orbit_momentum_campaign, shortened
to 300 s, fly the dispersed orbits and spacecraft they drew, and each row's verdict is its
cluster's peak share of the envelope against 80 % (the whole 50-case, 10-orbit campaign is run
from its command: `testbed campaign orbit_momentum_campaign`)."""

from __future__ import annotations

import json

from testbed.cli import main


def test_the_first_cases_of_the_orbit_campaign(tmp_path, capsys):
    args = ["campaign", "orbit_momentum_campaign", "--set", "sweep.samples=2", "--set", "sim.duration_s=300",
            "--out", str(tmp_path), "--workers", "1", "--json"]
    assert main(args) == 0
    rows = json.loads(capsys.readouterr().out)
    assert len(rows) == 2 and all(r["status"] == "ok" for r in rows)
    for row in rows:
        assert 380 <= row["applied:orbit.altitude_km"] <= 480
        assert 30 <= row["applied:orbit.inclination_deg"] <= 98
        assert row["passed"] == (row["peak_envelope_share"] <= 0.8 and row["peak_dipole_use"] <= 1.0)
    assert rows[0]["applied:orbit.altitude_km"] != rows[1]["applied:orbit.altitude_km"]
