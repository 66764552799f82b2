"""The singular surfaces of the 4-unit pyramid and the box cut by the plane y = 0, and where they
cross the x and z axes: the pictures and numbers of Wie's singularity analysis (J. Guid. Control
Dyn. 27(2), 2004) and Kurokawa's survey (J. Guid. Control Dyn. 30(5), 2007, section II).

Run: nice -n 5 .venv/bin/python bench/singular_surfaces.py [--points 200000] [--markdown]

The arrays are cmg_cluster's presets, compiled (their gimbal axes read back from the model, unit
rotors). Each surface H(u, e) = sum e_i (g_i x u) x g_i / |g_i x u| (momentum_envelope.py) is
sampled over --points Fibonacci directions u; the points with |H_y| < 0.004 h are drawn, coloured
by how many units the pattern turns against the envelope (0: the envelope, 1 or 2). The axis
crossings come from singular_crossings.ray_crossings, each checked on the compiled model (H and
sqrt det J J^T at the gimbal angles it gives) and typed by Bedrossian's test. Writes
docs/theory/singular_surfaces.svg and prints the crossings (--markdown: the table of
docs/theory/momentum-envelope.md, "Singular surfaces of the pyramid and the box").
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # run from a checkout, uninstalled
from testbed.steering.singularity_type import KIND_NAMES, singularity_type  # noqa: E402
from testbed.systems.cmg_cluster.envelope_command import cluster_of_array  # noqa: E402
from testbed.systems.cmg_cluster.momentum_envelope import singular_surface_points  # noqa: E402
from testbed.systems.cmg_cluster.singular_crossings import gimbal_angles, ray_crossings  # noqa: E402

FIGURE = ROOT / "docs" / "theory" / "singular_surfaces.svg"
PYRAMID_SKEW_DEG = math.degrees(math.acos(1.0 / math.sqrt(3.0)))  # 54.7356 deg
ARRAYS = {"pyramid, β = 54.74°": ("pyramid", PYRAMID_SKEW_DEG), "pyramid, β = 53.13°": ("pyramid", 53.130102354),
          "box (β = 90°)": ("box", None)}
PICTURED = ("pyramid, β = 54.74°", "box (β = 90°)")
SLICE = 0.004  # |H_y| / h of the points drawn
STARTS = 150   # solver starts per surface and axis (singular_crossings.ray_crossings)
FLAT = 1e-9    # a surface whose every point has |H_y| below this [h] lies in the plane: a sheet
COLOURS = {0: "#1c7ed6", 1: "#e8590c", 2: "#ae3ec9"}
LEGEND = {0: "envelope (every unit with u)", 1: "one unit against u", 2: "two units against u"}


def against(pattern) -> int:
    """How many units the pattern (or its negative, the same surface) turns against u."""
    minus = sum(1 for s in pattern if s < 0)
    return min(minus, len(pattern) - minus)


def slice_points(geometry, points: int) -> tuple[list[tuple[int, np.ndarray]], list[tuple[int, ...]]]:
    """(units against u, points (m, 2) of (H_x, H_z) / h with |H_y| < SLICE h) per surface that
    crosses the plane, and the patterns of the surfaces lying in it (sheets, not drawn)."""
    cut, sheets = [], []
    for pattern, P in singular_surface_points(None, points, 1.0, geometry.gimbal_axes).items():
        if np.abs(P[:, 1]).max() < FLAT:
            sheets.append(pattern)
        else:
            cut.append((against(pattern), P[np.abs(P[:, 1]) < SLICE][:, [0, 2]]))
    return cut, sheets


def axis_crossings(geometry, axis) -> list[dict]:
    """Every isolated crossing of every surface with the positive `axis`: distance / h, the units
    against u, the compiled model's H and sqrt det there, Bedrossian's type and the gimbal angles."""
    rows = []
    for signs in itertools.product((1, -1), repeat=len(geometry.gimbal_axes)):  # e and -e: one surface
        for c in ray_crossings(axis, signs, geometry.gimbal_axes, 1.0, STARTS):
            if not c.isolated:
                continue
            beta = gimbal_angles(c.unit_momenta, geometry.spin_axes_zero, geometry.turn_axes)
            H = geometry.momentum(beta)
            kind = singularity_type(geometry.unit_jacobian(beta), geometry.unit_jacobian_derivative(beta), H)
            rows.append({"distance": c.distance, "against": against(signs), "pattern": signs,
                         "model_H": H, "measure": geometry.singularity_measure(beta),
                         "kind": KIND_NAMES[kind.kind], "beta_deg": np.degrees(beta)})
    rows.sort(key=lambda r: -r["distance"])
    unique = []
    for r in rows:  # a crossing reached from two patterns (a degenerate state) is listed once
        if not any(abs(r["distance"] - u["distance"]) < 1e-6 and r["kind"] == u["kind"] for u in unique):
            unique.append(r)
    return unique


def figure(panels: dict[str, list], crossings: dict[str, dict], path: Path) -> None:
    """Two panels side by side, H_x across and H_z up, both in units of h, one dot per sampled point."""
    width, height, margin, gap, top, bottom = 900, 470, 50, 60, 30, 90
    side = (width - 2 * margin - gap) / 2
    extent = 4.3
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
             f'font-family="sans-serif" font-size="12">', f'<rect width="{width}" height="{height}" fill="white"/>']
    for k, (title, surfaces) in enumerate(panels.items()):
        x0 = margin + k * (side + gap)
        scale = min(side, height - top - bottom) / (2 * extent)
        cx, cy = x0 + side / 2, top + (height - top - bottom) / 2

        def sx(v, cx=cx, scale=scale):
            return cx + v * scale

        def sy(v, cy=cy, scale=scale):
            return cy - v * scale

        parts.append(f'<text x="{cx}" y="{top - 10}" text-anchor="middle" font-weight="bold">{title}</text>')
        parts.append(f'<line x1="{sx(-extent)}" y1="{sy(0)}" x2="{sx(extent)}" y2="{sy(0)}" stroke="#adb5bd"/>')
        parts.append(f'<line x1="{sx(0)}" y1="{sy(-extent)}" x2="{sx(0)}" y2="{sy(extent)}" stroke="#adb5bd"/>')
        parts.append(f'<text x="{sx(extent)}" y="{sy(0) - 6}" text-anchor="end">H_x / h</text>')
        parts.append(f'<text x="{sx(0) + 6}" y="{sy(extent) + 10}">H_z / h</text>')
        for v in (-4, -2, 2, 4):
            parts.append(f'<text x="{sx(v)}" y="{sy(0) + 14}" text-anchor="middle" fill="#868e96">{v}</text>')
            parts.append(f'<text x="{sx(0) - 4}" y="{sy(v) + 4}" text-anchor="end" fill="#868e96">{v}</text>')
        for level in (2, 1, 0):  # the envelope drawn last, on top
            pixels = {(round(sx(x)), round(sy(z))) for count, P in surfaces[0] if count == level for x, z in P}
            parts.extend(f'<circle cx="{x}" cy="{y}" r="0.9" fill="{COLOURS[level]}"/>' for x, y in sorted(pixels))
        if surfaces[1]:
            parts.append(f'<text x="{cx}" y="{height - bottom + 22}" text-anchor="middle">{len(surfaces[1])} '
                         f'surfaces lie in the plane itself (sheets, not drawn)</text>')
        for axis, rows in crossings[title].items():
            for r in rows:
                x, z = (r["distance"], 0.0) if axis == "x" else (0.0, r["distance"])
                parts.append(f'<circle cx="{sx(x):.1f}" cy="{sy(z):.1f}" r="4" fill="none" stroke="black"/>')
    for i, (level, label) in enumerate(LEGEND.items()):
        x = margin + i * 250
        parts.append(f'<circle cx="{x}" cy="{height - 40}" r="5" fill="{COLOURS[level]}"/>')
        parts.append(f'<text x="{x + 10}" y="{height - 36}">{label}</text>')
    parts.append(f'<text x="{margin}" y="{height - 14}">Cut by the plane H_y = 0 (points within {SLICE} h); '
                 f'circles: the isolated crossings of the x and z axes (table in momentum-envelope.md).</text>')
    parts.append("</svg>")
    path.write_text("\n".join(parts) + "\n")


def table(crossings: dict[str, dict]) -> list[str]:
    lines = ["| array | axis | distance | units against u | Bedrossian | gimbal angles [deg] | model: sqrt det JJᵀ |",
             "|---|---|---:|---:|---|---|---:|"]
    for title, per_axis in crossings.items():
        for axis, rows in per_axis.items():
            for r in rows:
                angles = ", ".join(f"{a:.1f}" for a in r["beta_deg"])
                lines.append(f"| {title} | {axis} | {r['distance']:.4f} h | {r['against']} | {r['kind']} | "
                             f"({angles}) | {r['measure']:.0e} |")
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=200_000, help="directions sampled per surface")
    parser.add_argument("--markdown", action="store_true", help="print the crossings as the docs' table")
    args = parser.parse_args(argv)
    panels, crossings = {}, {}
    for title, (preset, skew) in ARRAYS.items():
        geometry = cluster_of_array(preset, None, skew, 1.0)
        crossings[title] = {name: axis_crossings(geometry, axis)
                            for name, axis in (("x", [1.0, 0.0, 0.0]), ("z", [0.0, 0.0, 1.0]))}
        if title in PICTURED:
            panels[title] = slice_points(geometry, args.points)
    figure(panels, {t: crossings[t] for t in PICTURED}, FIGURE)
    print("\n".join(table(crossings)) if args.markdown else crossings)
    print(f"figure: {FIGURE.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
