"""The pseudo-inverse and Wie's off-diagonal SR inverse from the pyramid's singular start, side by
side (scenarios/pyramid_singular_escape.yaml; Wie 2005, J. Guid. Control Dyn. 28(5)).

Run: nice -n 5 .venv/bin/python bench/singular_escape.py

Flies the scenario with `pinv` and with `osr` (under a minute of wall time) and writes
docs/theory/singular_escape.svg: sqrt det(J J^T) and the torque delivered along x against time,
with the demand; prints each law's escape time (first control sample with sqrt det >= 0.1).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # run from a checkout, uninstalled
from testbed.runner import run_scenario  # noqa: E402
from testbed.scenario.loading import load_scenario  # noqa: E402

FIGURE = ROOT / "docs" / "theory" / "singular_escape.svg"
LAWS = {"pinv": ("pseudo-inverse (pinv)", "#c92a2a"), "osr": ("Wie's off-diagonal SR inverse (osr)", "#1c7ed6")}
ESCAPED = 0.1  # sqrt det(J J^T) taken as off the singular set


def flown(law: str) -> dict[str, np.ndarray]:
    """Time [s], sqrt det J J^T, torque wanted and delivered along x [N m] of the scenario under `law`."""
    result = run_scenario(load_scenario("pyramid_singular_escape", [f"pipeline.allocator.type={law}"]), None,
                          keep_data=True)
    if result.status != "ok":
        raise SystemExit(f"{law}: {result.status}: {result.error}")
    t, measure = result.trace["allocator/singularity"]
    _, wanted = result.trace["law/torque"]
    _, delivered = result.trace["allocator/torque_delivered"]
    return {"t": t, "measure": measure.ravel(), "wanted": wanted[:, 0], "delivered": delivered[:, 0]}


def figure(runs: dict[str, dict], path: Path) -> None:
    """Two panels one above the other, time across: sqrt det J J^T, and the torque along x."""
    width, left, right, panel, gap, top = 760, 70, 20, 150, 50, 20
    height = top + 2 * panel + gap + 80
    t_end = max(float(r["t"][-1]) for r in runs.values())

    def sx(t):
        return left + t / t_end * (width - left - right)

    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
             f'font-family="sans-serif" font-size="12">', f'<rect width="{width}" height="{height}" fill="white"/>']
    panels = [("sqrt det(J Jᵀ)", "measure", 0.0, 1.5, (0.0, 0.5, 1.0, 1.5)),
              ("torque along x [N m]", "delivered", -6.0, 1.0, (-6.0, -4.0, -2.0, 0.0))]
    for k, (label, key, lo, hi, ticks) in enumerate(panels):
        y0 = top + k * (panel + gap)

        def sy(v, y0=y0, lo=lo, hi=hi):
            return y0 + panel - (v - lo) / (hi - lo) * panel

        parts.append(f'<line x1="{left}" y1="{y0 + panel}" x2="{width - right}" y2="{y0 + panel}" stroke="black"/>')
        parts.append(f'<line x1="{left}" y1="{y0}" x2="{left}" y2="{y0 + panel}" stroke="black"/>')
        parts.append(f'<text x="{left + 6}" y="{y0 + 12}">{label}</text>')
        for v in ticks:
            parts.append(f'<text x="{left - 6}" y="{sy(v) + 4}" text-anchor="end">{v:g}</text>')
        for t in range(0, int(t_end) + 1, 2):
            parts.append(f'<text x="{sx(t)}" y="{y0 + panel + 14}" text-anchor="middle">{t}</text>')
        if key == "delivered":  # the demand, dashed
            r = runs["osr"]
            points = " ".join(f"{sx(t):.1f},{sy(v):.1f}" for t, v in zip(r["t"], r["wanted"]) if np.isfinite(v))
            parts.append(f'<polyline points="{points}" fill="none" stroke="black" stroke-dasharray="5,4"/>')
        else:
            parts.append(f'<line x1="{left}" y1="{sy(ESCAPED)}" x2="{width - right}" y2="{sy(ESCAPED)}" '
                         f'stroke="#adb5bd" stroke-dasharray="2,3"/>')
        for law, (_, colour) in LAWS.items():
            r = runs[law]
            points = " ".join(f"{sx(t):.1f},{sy(v):.1f}" for t, v in zip(r["t"], r[key]) if np.isfinite(v))
            parts.append(f'<polyline points="{points}" fill="none" stroke="{colour}" stroke-width="1.8"/>')
    y = height - 40
    parts.append(f'<text x="{(left + width - right) / 2}" y="{y - 14}" text-anchor="middle">time [s]</text>')
    for i, (label, colour) in enumerate(list(LAWS.values()) + [("demand", "black")]):
        x = left + i * 260
        dash = ' stroke-dasharray="5,4"' if label == "demand" else ""
        parts.append(f'<line x1="{x}" y1="{y + 12}" x2="{x + 24}" y2="{y + 12}" stroke="{colour}" '
                     f'stroke-width="2"{dash}/>')
        parts.append(f'<text x="{x + 30}" y="{y + 16}">{label}</text>')
    parts.append("</svg>")
    path.write_text("\n".join(parts) + "\n")


def main() -> int:
    runs = {law: flown(law) for law in LAWS}
    for law, r in runs.items():
        off = np.nonzero(r["measure"] >= ESCAPED)[0]
        escape = "never" if off.size == 0 else f"{r['t'][off[0]]:.2f} s"
        print(f"{law}: escape {escape}, peak sqrt det {np.nanmax(r['measure']):.3f}")
    figure(runs, FIGURE)
    print(f"figure: {FIGURE.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
