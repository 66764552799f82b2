"""`testbed envelope`: the CMG cluster's momentum envelope and singular surfaces as an .rrd.

    testbed envelope --alpha-deg A [--h H] [--points N] [--out PATH]

Compiles models/cmg_rhombus.xml at skew angle α and rotor momentum h, reads the gimbal axes
and h back from the compiled model (ClusterGeometry), and writes the external envelope and
the 7 internal singular surfaces (momentum_envelope.py beside this file) as 3D points. Prints
the envelope's extent along the body axes, which SEEDS §004 gives as 4h cos α (x),
4h sin α (y), 4h (z). α outside (0, 90) deg, h <= 0 or N < 1 is bad input (exit 2).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from testbed.cli.commands import EXIT_OK, command, reported
from testbed.errors import InputError
from testbed.recording.output_paths import output_path
from testbed.systems.cmg_rhombus.cluster import ClusterGeometry
from testbed.systems.cmg_rhombus.model import CmgRhombusParams, build
from testbed.systems.cmg_rhombus.momentum_envelope import EXTERNAL, singular_momenta, write_envelope_rrd

ALPHA_RANGE_DEG = (0.01, 89.99)  # at 0 or 90 deg the rhombus folds flat: the gimbal axes coincide
H_RANGE_NMS = (1e-6, 1e9)        # rotor momenta the compiled model (rotor inertia h / Omega) can hold
MAX_POINTS = 200_000  # directions per surface: 8 surfaces of this many points stay well under a GB


@command("envelope")
def add_parser(subparsers) -> None:
    p = subparsers.add_parser("envelope", help="write the CMG momentum envelope and singular surfaces to an .rrd")
    p.add_argument("--alpha-deg", type=float, required=True, help="rhombus skew angle α, in (0, 90) deg")
    p.add_argument("--h", type=float, default=1.0, help="rotor momentum h of each CMG [N m s] (default 1)")
    p.add_argument("--points", type=int, default=4000, help="directions sampled per surface (default 4000)")
    p.add_argument("--out", help="output .rrd (default runs/envelope_alpha<A>.rrd)")
    p.set_defaults(func=run)


def cluster_from_model(alpha_deg: float, h: float):
    """ClusterGeometry of the compiled rhombus model for α [deg] and h [N m s]."""
    model = build(CmgRhombusParams(alpha_deg=alpha_deg, rotor_momentum_nms=h), dt=1e-3)
    return ClusterGeometry.from_model(model)


def axis_extents(axes: np.ndarray, h: float) -> np.ndarray:
    """|H| of the envelope points in the directions +x, +y, +z (exact, u along each axis)."""
    return np.array([np.linalg.norm(singular_momenta(u, EXTERNAL, axes, h).sum(axis=1)[0]) for u in np.eye(3)])


def run(args) -> int:
    alpha = args.alpha_deg
    if not (math.isfinite(alpha) and ALPHA_RANGE_DEG[0] <= alpha <= ALPHA_RANGE_DEG[1]):
        raise InputError("--alpha-deg", f"must lie in [{ALPHA_RANGE_DEG[0]:g}, {ALPHA_RANGE_DEG[1]:g}] deg, got {alpha:g}")
    if not (math.isfinite(args.h) and H_RANGE_NMS[0] <= args.h <= H_RANGE_NMS[1]):
        raise InputError("--h", f"must lie in [{H_RANGE_NMS[0]:g}, {H_RANGE_NMS[1]:g}] N m s, got {args.h:g}")
    if not 1 <= args.points <= MAX_POINTS:
        raise InputError("--points", f"must be in [1, {MAX_POINTS}], got {args.points}")
    out = output_path(args.out or Path("runs") / f"envelope_alpha{alpha:g}.rrd")
    cluster = cluster_from_model(alpha, args.h)
    write_envelope_rrd(out, math.radians(alpha), cluster.h, args.points, axes=cluster.gimbal_axes)
    ext = axis_extents(cluster.gimbal_axes, cluster.h)
    a = math.radians(alpha)
    expected = 4 * cluster.h * np.array([math.cos(a), math.sin(a), 1.0])

    def report():
        print(f"momentum envelope, alpha = {alpha:g} deg, h = {cluster.h:g} N m s (gimbal axes from the model)")
        for name, label, value, exact in zip("xyz", ("4h cos a", "4h sin a", "4h"), ext, expected):
            print(f"  extent along {name}: {value:.6g} N m s ({label} = {exact:.6g})")
        print(f"trace: {out}")
    return reported(EXIT_OK, report)
