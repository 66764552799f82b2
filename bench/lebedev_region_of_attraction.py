"""The flagship one-gyro spin-up's region of attraction: success against the initial rate and the
observer's start-up time, from a campaign.

Run: nice -n 5 .venv/bin/python bench/lebedev_region_of_attraction.py [--samples 16] [--seed 2026]
     [--startups 50,100,150,200,300] [--out runs/lebedev_roa] [--workers 1] [--report-only]

The campaign is lebedev_spinup_campaign (scenarios/lebedev_spinup_campaign.yaml) with its design
and checks as shipped, the start-up time `pipeline.estimator.startup_s` a grid dimension and the
initial rate drawn uniform in +-0.5 deg/s per axis (the same draws at every start-up time); the
other dispersions are left out (they change nothing visible in the shipped campaign,
docs/campaigns.md). Prints the markdown table of docs/theory/lebedev.md ("The region of
attraction") and writes its figure, an SVG scatter of omega_y(0) against the start-up time, to
docs/theory/lebedev_roa.svg. `--report-only` redraws both from the campaign table in --out.
"""

from __future__ import annotations

import argparse
import csv
import subprocess
import sys
import tempfile
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # run from a checkout, uninstalled
from testbed.scenario.loading import resolve_path  # noqa: E402
from testbed.scenario.yaml_reading import read_yaml  # noqa: E402

FIGURE = ROOT / "docs" / "theory" / "lebedev_roa.svg"
RATE, STARTUP = "initial.omega_deg_s[1]", "pipeline.estimator.startup_s"
# what a case ended as, in the order the table and the legend give them: (label, colour)
OUTCOMES = {"pass": ("passed", "#2b8a3e"), "diverged": ("observer diverged (method_failed)", "#c92a2a"),
            "steady": ("ran to the end, failed its checks", "#e67700"), "other": ("other status", "#495057")}


def campaign_file(folder: Path, samples: int, seed: int, startups: list[float]) -> Path:
    """The flagship campaign with the start-up time a grid and only the initial rate drawn."""
    data = read_yaml(resolve_path("lebedev_spinup_campaign"))
    data["name"] = "lebedev_region_of_attraction"
    data["sweep"] = {"seed": seed, "samples": samples, "grid": {STARTUP: startups},
                     "dispersions": {"initial.omega_deg_s": {"uniform": [-0.5, 0.5]}}}
    path = folder / "lebedev_region_of_attraction.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def outcome(row: dict) -> str:
    if row["passed"] == "True":
        return "pass"
    if row["status"] == "method_failed":
        return "diverged"
    return "steady" if row["status"] == "ok" else "other"


def read_rows(out: Path) -> list[dict]:
    (table,) = [p for p in out.glob("*.csv")]
    with table.open() as f:
        return list(csv.DictReader(f))


def report(rows: list[dict]) -> list[str]:
    """The markdown table: per start-up time and band of omega_y(0), passed of all (and how many
    diverged), and the observer's error when the loop closed in the passing and diverged cases."""
    bands = [(-0.5, -0.25), (-0.25, 0.0), (0.0, 0.25), (0.25, 0.5)]
    lines = ["| start-up [s] | " + " | ".join(f"w_y(0) in [{lo:g}, {hi:g})" for lo, hi in bands)
             + " | all | estimate's error when the loop closed: passed / diverged [deg/s] |",
             "|---:|" + "---|" * (len(bands) + 2)]
    for startup in sorted({float(r[STARTUP]) for r in rows}):
        here = [r for r in rows if float(r[STARTUP]) == startup]
        cells = []
        for lo, hi in bands + [(-1.0, 1.0)]:
            band = [outcome(r) for r in here if lo <= float(r[RATE]) < hi]
            cells.append(f"{band.count('pass')}/{len(band)}" + (f" ({band.count('diverged')} div)"
                                                              if band.count("diverged") else ""))
        closing = {kind: [float(r["estimation_error_at_closing_deg_s"]) for r in here if outcome(r) == kind]
                   for kind in ("pass", "diverged")}
        spans = ["-" if not v else f"{min(v):.2g}-{max(v):.2g}" for v in closing.values()]
        lines.append(f"| {startup:g} | " + " | ".join(cells) + f" | {' / '.join(spans)} |")
    return lines


def figure(rows: list[dict], path: Path) -> None:
    """An SVG scatter: omega_y(0) [deg/s] across, the start-up time [s] up, one mark per case."""
    width, height, left, bottom, top, right = 720, 360, 70, 50, 20, 260
    startups = sorted({float(r[STARTUP]) for r in rows})
    y_lo, y_hi = 0.0, max(startups) * 1.1

    def sx(v):
        return left + (v + 0.5) / 1.0 * (width - left - right)

    def sy(v):
        return height - bottom - (v - y_lo) / (y_hi - y_lo) * (height - bottom - top)

    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
             f'font-family="sans-serif" font-size="12">',
             f'<rect width="{width}" height="{height}" fill="white"/>',
             f'<line x1="{left}" y1="{sy(y_lo)}" x2="{sx(0.5)}" y2="{sy(y_lo)}" stroke="black"/>',
             f'<line x1="{left}" y1="{sy(y_lo)}" x2="{left}" y2="{sy(y_hi)}" stroke="black"/>']
    for v in (-0.5, -0.25, 0.0, 0.25, 0.5):
        parts.append(f'<text x="{sx(v)}" y="{sy(y_lo) + 16}" text-anchor="middle">{v:g}</text>')
    for v in startups:
        parts.append(f'<text x="{left - 8}" y="{sy(v) + 4}" text-anchor="end">{v:g}</text>')
    parts.append(f'<text x="{sx(0.0)}" y="{height - 12}" text-anchor="middle">initial rate about y, '
                 f'omega_y(0) [deg/s]</text>')
    parts.append(f'<text x="16" y="{sy(y_hi / 2)}" text-anchor="middle" transform="rotate(-90 16 '
                 f'{sy(y_hi / 2)})">observer start-up time [s]</text>')
    for r in rows:
        _, colour = OUTCOMES[outcome(r)]
        parts.append(f'<circle cx="{sx(float(r[RATE])):.1f}" cy="{sy(float(r[STARTUP])):.1f}" r="5" '
                     f'fill="{colour}" fill-opacity="0.8"/>')
    for i, (label, colour) in enumerate(OUTCOMES.values()):
        y = top + 20 + 22 * i
        parts.append(f'<circle cx="{width - right + 20}" cy="{y}" r="5" fill="{colour}"/>')
        parts.append(f'<text x="{width - right + 32}" y="{y + 4}">{label}</text>')
    parts.append("</svg>")
    path.write_text("\n".join(parts) + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--samples", type=int, default=16)
    parser.add_argument("--seed", type=int, default=2026)
    parser.add_argument("--startups", default="50,100,150,200,300")
    parser.add_argument("--out", type=Path, default=ROOT / "runs" / "lebedev_roa")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--report-only", action="store_true")
    args = parser.parse_args()
    if not args.report_only:
        with tempfile.TemporaryDirectory() as folder:
            spec = campaign_file(Path(folder), args.samples, args.seed,
                                 [float(s) for s in args.startups.split(",")])
            subprocess.run([sys.executable, "-m", "testbed", "campaign", str(spec), "--out", str(args.out),
                            "--workers", str(args.workers)], check=False)
    rows = read_rows(args.out)
    print("\n".join(report(rows)))
    figure(rows, FIGURE)
    print(f"figure: {FIGURE.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
