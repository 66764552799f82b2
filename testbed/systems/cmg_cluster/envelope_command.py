"""`testbed envelope`: a CMG cluster's momentum envelope, its extents and its singular surfaces.

    testbed envelope SCENARIO [--points N] [--out PATH] [--json]
    testbed envelope --array PRESET [--count N] [--skew-deg B] [--h H] [--points N] [--out PATH] [--json]
    testbed envelope --alpha-deg A [--h H] [--points N] [--out PATH] [--json]

The cluster is a scenario's (its model built as the run builds it), a preset array of
cmg_cluster (arrays.py) or the seed's rhombus at angle α (models/cmg_rhombus.xml); the gimbal
axes and rotor momenta are read back from the compiled model (ClusterGeometry). Prints the
envelope's support S(u) = Σ h_i |u × g_i| along x, y and z and its least and largest over all
directions (momentum_gauge.support_extremes), and writes the external envelope and the internal
singular surfaces (momentum_envelope.py) as 3D points to an .rrd. For the rhombus SEEDS §004
gives the extents 4h cos α (x), 4h sin α (y), 4h (z), printed beside them. Bad input (a value out
of range, a scenario without a CMG cluster, two clusters named) is one line, exit 2.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from testbed.cli.commands import EXIT_OK, command, reported
from testbed.errors import InputError
from testbed.recording.output_paths import output_path
from testbed.systems.cmg_cluster.arrays import MAX_UNITS, MIN_UNITS, PRESETS, ArrayParams
from testbed.systems.cmg_cluster.model import CmgClusterParams
from testbed.systems.cmg_cluster.hybrid_plant import HybridBus
from testbed.systems.cmg_cluster.model import build as build_cluster
from testbed.systems.cmg_cluster.cluster import ClusterGeometry
from testbed.systems.cmg_rhombus.model import CmgRhombusParams, build
from testbed.systems.cmg_cluster.momentum_envelope import write_envelope_rrd
from testbed.systems.cmg_cluster.momentum_gauge import envelope_support, support_extremes

ALPHA_RANGE_DEG = (0.01, 89.99)  # at 0 or 90 deg the rhombus folds flat: the gimbal axes coincide
SKEW_RANGE_DEG = (0.01, 90.0)
H_RANGE_NMS = (1e-6, 1e9)        # rotor momenta the compiled model (rotor inertia h / Omega) can hold
MAX_POINTS = 200_000  # directions per surface
MAX_SURFACE_POINTS = 1_600_000  # points over all 2^(n-1) surfaces: the rhombus's 8 x 200 000, well under a GB
RHOMBUS_EXTENTS = {"x": "4h cos a", "y": "4h sin a", "z": "4h"}  # SEEDS §004
BUILD_DT_S = 1e-3  # the step the model is compiled with (nothing is stepped)


@command("envelope")
def add_parser(subparsers) -> None:
    p = subparsers.add_parser("envelope", help="a CMG cluster's momentum envelope: its extents and surfaces (.rrd)")
    p.add_argument("scenario", nargs="?", help="a scenario (name or path) whose CMG cluster to take")
    p.add_argument("--array", help=f"a preset array of cmg_cluster: {', '.join(p for p in PRESETS if p != 'custom')}")
    p.add_argument("--count", type=int, help=f"--array pyramid: number of units, {MIN_UNITS} ... {MAX_UNITS}")
    p.add_argument("--skew-deg", type=float, help="--array pyramid or roof: the gimbal axes' angle from z [deg]")
    p.add_argument("--alpha-deg", type=float, help="the seed's rhombus at skew angle α, in (0, 90) deg")
    p.add_argument("--h", type=float, default=1.0, help="rotor momentum h of each CMG [N m s] (default 1)")
    p.add_argument("--points", type=int, default=4000, help="directions sampled per surface (default 4000)")
    p.add_argument("--out", help="output .rrd (default runs/envelope_<cluster>.rrd)")
    p.add_argument("--json", action="store_true", help="print the extents as one JSON object")
    p.set_defaults(func=run)


def cluster_from_model(alpha_deg: float, h: float):
    """ClusterGeometry of the compiled rhombus model for α [deg] and h [N m s]."""
    return ClusterGeometry.from_model(build(CmgRhombusParams(alpha_deg=alpha_deg, rotor_momentum_nms=h), BUILD_DT_S))


def cluster_of_array(preset: str, count: int | None, skew_deg: float | None, h: float) -> ClusterGeometry:
    """ClusterGeometry of a cmg_cluster preset array with rotor momentum h [N m s]."""
    params = CmgClusterParams(array=ArrayParams(preset=preset, count=count, skew_deg=skew_deg), rotor_momentum_nms=h)
    params.array.validate("--array")
    return ClusterGeometry.from_model(build_cluster(params, BUILD_DT_S))


def cluster_of_scenario(name: str) -> ClusterGeometry:
    """The CMG cluster of a scenario's plant, built as the run builds it."""
    from testbed.scenario.loading import load_scenario  # the scenario machinery, only for this mode
    from testbed.systems.registry import make_plant

    scenario = load_scenario(name)
    geometry = make_plant(scenario).description()
    if isinstance(geometry, HybridBus):  # the wheels hold no envelope of their own here
        geometry = geometry.cluster
    if not isinstance(geometry, ClusterGeometry):
        raise InputError("scenario", f"{name}: system {scenario.system} has no CMG cluster")
    return geometry


def axis_extents(axes: np.ndarray, rotor_momenta) -> np.ndarray:
    """S(u) [N m s] along +x, +y, +z: the envelope's extent along each body axis (exact)."""
    return envelope_support(np.eye(3), axes, rotor_momenta)


def envelope_summary(cluster: ClusterGeometry, points: int = 4000) -> dict:
    """What `testbed envelope` prints: the extents along x, y, z, the least and largest S(u) with
    their directions [N m s], the unit count and rotor momenta."""
    (least, u_least), (largest, u_largest) = support_extremes(cluster.gimbal_axes, cluster.rotor_momentum, points)
    return {"units": len(cluster.gimbal_axes), "rotor_momenta_nms": cluster.rotor_momentum.tolist(),
            "extent_nms": dict(zip("xyz", axis_extents(cluster.gimbal_axes, cluster.rotor_momentum).tolist())),
            "least_nms": least, "least_direction": u_least.tolist(),
            "largest_nms": largest, "largest_direction": u_largest.tolist()}


def run(args) -> int:
    modes = [m for m, given in (("SCENARIO", args.scenario is not None), ("--array", args.array is not None),
                                ("--alpha-deg", args.alpha_deg is not None)) if given]
    if len(modes) != 1:
        raise InputError("usage", "name one cluster: a SCENARIO, --array PRESET or --alpha-deg A"
                         + (f" (got {' and '.join(modes)})" if modes else ""))
    if not (math.isfinite(args.h) and H_RANGE_NMS[0] <= args.h <= H_RANGE_NMS[1]):
        raise InputError("--h", f"must lie in [{H_RANGE_NMS[0]:g}, {H_RANGE_NMS[1]:g}] N m s, got {args.h:g}")
    if not 1 <= args.points <= MAX_POINTS:
        raise InputError("--points", f"must be in [1, {MAX_POINTS}], got {args.points}")
    if args.array is None and (args.count is not None or args.skew_deg is not None):
        raise InputError("--count" if args.count is not None else "--skew-deg", "goes with --array")
    exact = None
    if args.alpha_deg is not None:
        alpha = args.alpha_deg
        if not (math.isfinite(alpha) and ALPHA_RANGE_DEG[0] <= alpha <= ALPHA_RANGE_DEG[1]):
            raise InputError("--alpha-deg", f"must lie in [{ALPHA_RANGE_DEG[0]:g}, {ALPHA_RANGE_DEG[1]:g}] deg, "
                             f"got {alpha:g}")
        label, cluster = f"alpha{alpha:g}", cluster_from_model(alpha, args.h)
        a = math.radians(alpha)
        exact = dict(zip("xyz", 4 * cluster.h * np.array([math.cos(a), math.sin(a), 1.0])))
        title = f"alpha = {alpha:g} deg, h = {cluster.h:g} N m s"
    elif args.array is not None:
        if args.array not in PRESETS or args.array == "custom":
            raise InputError("--array", f"must be one of {', '.join(p for p in PRESETS if p != 'custom')}, "
                             f"got {args.array!r}")
        if args.skew_deg is not None and not (math.isfinite(args.skew_deg)
                                              and SKEW_RANGE_DEG[0] <= args.skew_deg <= SKEW_RANGE_DEG[1]):
            raise InputError("--skew-deg", f"must lie in [{SKEW_RANGE_DEG[0]:g}, {SKEW_RANGE_DEG[1]:g}] deg, "
                             f"got {args.skew_deg:g}")
        if args.count is not None and not MIN_UNITS <= args.count <= MAX_UNITS:
            raise InputError("--count", f"must be in [{MIN_UNITS}, {MAX_UNITS}], got {args.count}")
        cluster = cluster_of_array(args.array, args.count, args.skew_deg, args.h)
        label = args.array + (f"{args.count}" if args.count else "") + (f"_skew{args.skew_deg:g}" if args.skew_deg else "")
        title = f"array {label}, h = {cluster.h:g} N m s"
    else:
        cluster = cluster_of_scenario(args.scenario)
        label, title = Path(args.scenario).stem, f"scenario {args.scenario}"
    surfaces = 2 ** (len(cluster.gimbal_axes) - 1)
    if args.points * surfaces > MAX_SURFACE_POINTS:
        raise InputError("--points", f"{args.points} directions on each of the {surfaces} surfaces exceed "
                         f"{MAX_SURFACE_POINTS} points: at most {MAX_SURFACE_POINTS // surfaces}")
    out = output_path(args.out or Path("runs") / f"envelope_{label}.rrd")
    summary = envelope_summary(cluster)
    write_envelope_rrd(out, None, cluster.rotor_momentum, args.points, axes=cluster.gimbal_axes)
    summary["trace"] = str(out)

    def report():
        if args.json:
            print(json.dumps(summary))
            return
        print(f"momentum envelope, {title}, {summary['units']} units (gimbal axes from the model)")
        for axis, value in summary["extent_nms"].items():
            beside = "" if exact is None else f" ({RHOMBUS_EXTENTS[axis]} = {exact[axis]:.6g})"
            print(f"  extent along {axis}: {value:.6g} N m s{beside}")
        for name in ("least", "largest"):
            u = np.round(summary[f"{name}_direction"], 4).tolist()
            print(f"  {name} over directions: {summary[f'{name}_nms']:.6g} N m s, along {u}")
        print(f"trace: {out}")
    return reported(EXIT_OK, report)
