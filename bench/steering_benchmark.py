"""docs/theory/steering.md, "Steering benchmark": every steering law on the same momentum paths, on any
CMG array, binned by how much of the envelope's support each asks for.

The benchmark isolates the steering problem (Valk, Berry & Vallery 2018 call for such a sweep): an
array of ARRAYS (unit rotor momenta h = 1, beta'max = 30 deg/s; the rhombus is reorient_near_singular's)
must follow a rest-to-rest momentum path H_w(t) = r d 4 tau (1 - tau), tau = t / T (the cluster momentum
-I omega of an eigenaxis slew with SEEDS §004's cubic angle profile, T = 40 s), from a zero-momentum
start set, gimbal kinematics only (beta_{k+1} = beta_k + dt beta'_k, dt = 0.05 s, the control period;
no bus dynamics). Each step asks the law for the momentum still missing,
b_k = (H_w(t_{k+1}) - H(beta_k)) / dt (exact-torque feedback on the residual), with the step inputs
the allocator stage gives (testbed.steering.STEP_INPUTS) and its rcond (STAGE_RCOND).

Cases (reproducible by seed): d uniform on the sphere, the peak r = f S(d) with
S(d) = sum_i h_i sqrt(1 - (d . g_i)^2) the envelope's support function along d (momentum_gauge.py)
and f uniform from 0.2 h / S(d) to 0.95, the start set one of the array's zero-momentum family
(a, -a, a, -a, ...) (the rhombus: (a, -a, -a, a)) at a = 45, 60, 30 deg where sqrt det >= 0.3.
The envelope's radius E(d) <= S(d) along d (equal where the envelope's normal is d): a case with
r > E(d) is beyond every gimbal state, counted apart and not in the shares. `--sweep N` adds the
Valk-style grid: N Fibonacci directions x every start set x FRACTIONS. Per law and bin of f: the
share of cases with exact torque (max |h J beta' - b| <= 1e-3 of the peak |b|) and
sqrt(det J J^T) >= 0.05 throughout, the peak gimbal rate, the final momentum error |H(beta_T)|/h, and
the seconds with sqrt det < 0.1. The usable fraction of the envelope of a law is the upper edge of
the largest bin (and all below) where it reaches 95 %. A law that cannot steer the array (4 units
only) is refused, not run. It prints the table and writes the exact shares as bar charts (`--rrd`).

    .venv/bin/python bench/steering_benchmark.py [--array rhombus] [--slews 200] [--seed 29] [--sweep 0]
                                                 [--laws pinv,...] [--markdown] [--duration-s 40] [--rate-deg-s 30]
                                                 [--csv runs/steering_benchmark.csv] [--rrd runs/steering_benchmark.rrd]
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

from testbed.steering import FOUR_UNIT_LAWS, LAW_OPTIONS, STEERING_LAWS
from testbed.steering.planned_path import PlannedPath, plan_gimbal_path
from testbed.steering.planned_stage import PlannedAllocator
from testbed.steering.stage import STAGE_RCOND
from testbed.systems.cmg_cluster.arrays import ArrayParams, layout
from testbed.systems.cmg_cluster.arrays import rhombus_axes
from testbed.systems.cmg_cluster.cluster import ClusterGeometry
from testbed.systems.cmg_cluster.momentum_gauge import envelope_support, fibonacci_sphere

SEED = 29
ALPHA_DEG, RATE_MAX_DEG_S = 54.7356, 30.0
DURATION_S, DT_S = 40.0, 0.05
# The arrays of docs/theory/steering.md's table: name -> the cmg_cluster `array:` block (the rhombus: the seed's).
ARRAYS = {"rhombus": None,
          "pyramid": ArrayParams(preset="pyramid"),
          "pyramid_53": ArrayParams(preset="pyramid", skew_deg=float(np.degrees(np.arccos(0.6)))),
          "box": ArrayParams(preset="box"),
          "roof": ArrayParams(preset="roof"),
          "pyramid_6": ArrayParams(preset="pyramid", count=6)}
START_ANGLES_DEG = (45.0, 60.0, 30.0)
START_CLEAR = 0.3  # a start set must have sqrt det >= this (the pyramid's (30, -30, 30, -30) deg is singular)
LOWEST_H, HIGHEST_FRACTION = 0.2, 0.95
FRACTIONS = (0.3, 0.5, 0.7, 0.8, 0.9)
BINS = (0.0, 0.3, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95)
EXACT, CLEAR, NEAR = 1e-3, 0.05, 0.1
LAWS = ("pinv", "sr", "gsr", "minimax", "minimax_avoid", "osr", "sda", "pga", "planned")
PLANNED = "planned"  # the plan of testbed.steering.planned_path, tracked by pga's null motion
PRESLEW_S = 5.0  # the rest before the slew (reorient_near_singular's start_s) the planned law may reconfigure in


def geometry(array: str = "rhombus") -> ClusterGeometry:
    """The benchmark's cluster `array` (a key of ARRAYS) with h = 1; the rhombus is reorient_near_singular's."""
    if array == "rhombus":
        e, g, _ = rhombus_axes(np.radians(ALPHA_DEG))
        return ClusterGeometry(g, e, np.ones(4), 1.0)
    units = layout(ARRAYS[array])
    return ClusterGeometry(units.gimbal_axes, units.spin_axes, np.ones(units.count), 1.0)


def start_sets(geo: ClusterGeometry) -> np.ndarray:
    """The zero-momentum start sets [deg] (k, n) of the module doc: the family at START_ANGLES_DEG with
    sqrt det >= START_CLEAR."""
    n = len(geo.gimbal_axes)
    pattern = np.array([1.0, -1.0, -1.0, 1.0]) if np.allclose(geo.gimbal_axes[2], geo.gimbal_axes[0]) \
        else (-1.0) ** np.arange(n)  # the rhombus shares gimbal axes 1, 3 (SEEDS §004); the others alternate
    sets = [a * pattern for a in START_ANGLES_DEG if geo.singularity_measure(np.radians(a * pattern)) >= START_CLEAR]
    for beta in sets:
        if np.linalg.norm(geo.momentum(np.radians(beta))) > 1e-9:
            raise ValueError(f"start set {beta} holds momentum: this array has no (a, -a, ...) zero-momentum family")
    return np.array(sets)


def support(geo: ClusterGeometry, direction) -> float:
    """S(d) [h] = sum_i h_i sqrt(1 - (d . g_i)^2): the most momentum the cluster holds along the unit d (momentum_gauge.py)."""
    return float(envelope_support(np.asarray(direction, float)[None], geo.gimbal_axes, geo.rotor_momentum / geo.h)[0])


def envelope_radius(geo: ClusterGeometry, direction) -> float:
    """E(d) [h]: the largest |H| the cluster holds along the unit d (1 / gauge, momentum_gauge.py), <= S(d)."""
    gauge, _ = geo.momentum_gauge(np.asarray(direction, float)[None])
    return float(1.0 / gauge[0])


def refusal(law: str, geo: ClusterGeometry) -> str:
    """Why `law` cannot steer the array ("" if it can): the allocator stage's own reason."""
    reason = PlannedAllocator.four_units_only if law == PLANNED else FOUR_UNIT_LAWS.get(law, "")
    return reason if reason and len(geo.gimbal_axes) != 4 else ""


def cases(slews: int, seed: int = SEED, sweep: int = 0, geo: ClusterGeometry | None = None) -> list[dict]:
    """{direction, fraction, peak_h, start, beyond}: `slews` random cases, then the sweep grid (module doc);
    `start` indexes start_sets(geo); `beyond`: the peak lies outside the envelope (r > E(d))."""
    geo = geo or geometry()
    starts, rng, out = len(start_sets(geo)), np.random.default_rng(seed), []

    def case(d, fraction, start):
        return {"direction": d.tolist(), "fraction": fraction, "peak_h": fraction * support(geo, d), "start": start}

    for _ in range(slews):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        out.append(case(d, float(rng.uniform(LOWEST_H / support(geo, d), HIGHEST_FRACTION)), int(rng.integers(starts))))
    for d in (fibonacci_sphere(sweep) if sweep else []):
        out += [case(d, f, s) for s in range(starts) for f in FRACTIONS]
    if out:  # the envelope's gauge of every peak at once: above 1, no gimbal state holds it
        gauge, _ = geo.momentum_gauge(np.array([c["peak_h"] * np.array(c["direction"]) for c in out]))
        for c, g in zip(out, gauge):
            c["beyond"] = bool(g > 1.0)
    return out


def wanted_momentum(case: dict, t) -> np.ndarray:
    """H_w(t) = r d 4 tau (1 - tau) [h], (..., 3)."""
    tau = np.clip(np.asarray(t, float) / DURATION_S, 0.0, 1.0)
    return (case["peak_h"] * 4 * tau * (1 - tau))[..., None] * np.asarray(case["direction"])


def planned_path(case: dict, geo: ClusterGeometry, step_s: float = 0.1):
    """The plan of testbed.steering.planned_path for the case's H_w(t) = s(t) d (0.1 s steps), its reconfiguration
    at rest within PRESLEW_S at the rate limit; None when refused."""
    times = np.linspace(0.0, DURATION_S, int(round(DURATION_S / step_s)) + 1)
    rate_max = np.radians(RATE_MAX_DEG_S)
    plan = plan_gimbal_path(lambda beta: geo.momentum(beta) / geo.h, geo.unit_jacobian, np.radians(start_sets(geo)[case["start"]]),
                            case["direction"], times, wanted_momentum(case, times) @ np.asarray(case["direction"]),
                            rate_max, reconfiguration_travel=rate_max * PRESLEW_S)
    return plan if isinstance(plan, PlannedPath) else None


def fly(law: str, case: dict, geo: ClusterGeometry | None = None, duration_s: float | None = None,
        dt: float = DT_S, history: bool = False) -> dict:
    """One law on one case (module doc): its figures, and with `history` the flown angles at every step
    ("angles", (steps + 1, n)). `planned` plans the path before the slew (planned_path) and tracks it
    with pga's null motion towards the plan's next angles (gain 1/dt); a refused plan is not flown and
    counts as not exact."""
    geo = geo or geometry()
    rate_max = np.radians(RATE_MAX_DEG_S)
    beta = np.radians(start_sets(geo)[case["start"]])
    plan = None
    labels = {"law": law, "fraction": case["fraction"], "peak_h": case["peak_h"], "beyond": case["beyond"]}
    if law == PLANNED:
        plan = planned_path(case, geo)
        if plan is None:
            return labels | {"torque_error_rel": np.nan, "min_singularity_measure": np.nan, "peak_gimbal_rate_deg_s": 0.0,
                             "final_momentum_error_h": np.nan, "near_singular_s": 0.0, "exact": False, "refused": True}
        beta = plan.angles[0].copy()
    steer = STEERING_LAWS["pga" if plan else law]
    options = set(LAW_OPTIONS["pga" if plan else law])
    start, start_jacobian = beta.copy(), geo.unit_jacobian(beta)
    fixed = {"rcond": STAGE_RCOND} if "rcond" in options else {}
    if "preferred_gimbal_angles" in options:
        fixed["preferred_gimbal_angles"] = start
    if "preferred_jacobian" in options:
        fixed["preferred_jacobian"] = start_jacobian
    steps = int(round((DURATION_S if duration_s is None else duration_s) / dt))
    times = dt * np.arange(steps + 1)
    wanted = wanted_momentum(case, times)
    program_rate = np.abs(np.diff(wanted, axis=0) / dt).max() if steps else 0.0
    peak, error, lowest, near, flown = 0.0, 0.0, np.inf, 0, [beta]
    for k in range(steps):
        J = geo.unit_jacobian(beta)
        b = (wanted[k + 1] - geo.momentum(beta)) / dt
        inputs = dict(fixed)
        if "t" in options:
            inputs["t"] = times[k]
        if "column_derivative" in options:
            inputs["column_derivative"] = geo.unit_jacobian_derivative(beta)
        if "gimbal_angle" in options:
            inputs["gimbal_angle"] = beta
        if plan is not None:
            inputs.update(preferred_gimbal_angles=plan.at(times[k + 1]), null_gain_per_s=1.0 / dt)
        if "peak_rate_so_far" in options:
            inputs["peak_rate_so_far"] = peak
        result = steer(J, 1.0, b, rate_max, **inputs)
        peak = max(peak, float(np.abs(result.beta_rate).max()))
        error = max(error, float(np.linalg.norm(result.hdot_delivered - b)))
        lowest = min(lowest, result.singularity_measure)
        near += result.singularity_measure < NEAR
        beta = beta + dt * result.beta_rate
        flown.append(beta)
    lowest = min(lowest, geo.singularity_measure(beta))
    torque_error = error / max(program_rate * np.sqrt(3), 1e-300)
    return ({"angles": np.array(flown)} if history else {}) | labels | {"torque_error_rel": torque_error, "min_singularity_measure": lowest,
            "peak_gimbal_rate_deg_s": float(np.degrees(peak)),
            "final_momentum_error_h": float(np.linalg.norm(geo.momentum(beta) - wanted[-1])),
            "near_singular_s": dt * near, "exact": bool(torque_error <= EXACT and lowest >= CLEAR), "refused": False}


def bin_of(fraction: float) -> int:
    return int(np.searchsorted(BINS, fraction, side="right") - 1)


def within(rows: list[dict]) -> list[dict]:
    """The rows whose peak the envelope holds (the shares count only these)."""
    return [r for r in rows if not r["beyond"]]


def table(rows: list[dict], laws, refused: dict[str, str] | None = None) -> str:
    """Per law and bin of f (cases within the envelope): exact share, peak rate (max), final error (max),
    near-singular s (mean), plans refused (planned only); a law of `refused` {law: reason} has one line."""
    refused = refused or {}
    lines = [f"{'law':<14}{'bin of f':<12}{'n':>4}{'exact %':>9}{'peak deg/s':>12}{'final |dH|/h':>14}"
             f"{'near s':>8}{'refused':>9}"]
    for law in laws:
        if law in refused:
            lines.append(f"{law:<14}refused, not run: {refused[law]}")
            continue
        mine = [r for r in within(rows) if r["law"] == law]
        for i in range(len(BINS) - 1):
            cell = [r for r in mine if bin_of(r["fraction"]) == i]
            if not cell:
                continue
            exact = 100.0 * np.mean([r["exact"] for r in cell])
            lines.append(f"{law:<14}{f'{BINS[i]:.2f}-{BINS[i + 1]:.2f}':<12}{len(cell):>4}{exact:>9.0f}"
                         f"{max(r['peak_gimbal_rate_deg_s'] for r in cell):>12.1f}"
                         f"{np.nanmax([r['final_momentum_error_h'] for r in cell] + [0.0]):>14.2e}"
                         f"{np.mean([r['near_singular_s'] for r in cell]):>8.1f}"
                         f"{sum(r['refused'] for r in cell):>9}")
        lines.append(f"{law:<14}usable up to f = {usable_fraction(rows, law):.2f} of the envelope")
    return "\n".join(lines)


def markdown(rows: list[dict], laws, refused: dict[str, str], array: str, seed: int, slews: int, sweep: int) -> str:
    """docs/theory/steering.md's table for one array: the exact share per bin of f and the usable fraction
    per law, refused laws named; the caption gives the seed, the sample and the cases beyond the envelope."""
    first = [r for r in rows if r["law"] == next(law for law in laws if law not in refused)] if len(refused) < len(laws) else []
    counts = [sum(bin_of(r["fraction"]) == i for r in within(first)) for i in range(len(BINS) - 1)]
    beyond = [sum(bin_of(r["fraction"]) == i for r in first if r["beyond"]) for i in range(len(BINS) - 1)]
    head = " | ".join(f"{BINS[i]:g}–{BINS[i + 1]:g}" for i in range(len(BINS) - 1))
    lines = [f"{array}: seed {seed}, {slews} random slews + {sweep} sweep directions; within the envelope per bin "
             f"{', '.join(map(str, counts))} cases (beyond it, not counted: {', '.join(map(str, beyond))}).", "",
             f"| law | {head} | usable up to f |", "|---|" + "---:|" * len(BINS)]
    for law in laws:
        if law in refused:
            lines.append(f"| {law} | refused: {refused[law]} |" + " |" * (len(BINS) - 1))
            continue
        cells = " | ".join("" if np.isnan(v) else f"{v:.0f} %" for v in exact_shares(rows, law))
        lines.append(f"| {law} | {cells} | {usable_fraction(rows, law):.2f} |")
    return "\n".join(lines)


def usable_fraction(rows: list[dict], law: str, share: float = 0.95) -> float:
    """Upper edge of the largest bin such that it and every bin below it reach `share` exact."""
    edge = BINS[0]
    for i, exact in enumerate(exact_shares(rows, law)):
        if exact < 100.0 * share:  # an empty bin (nan) does not stop the count
            break
        edge = BINS[i + 1]
    return edge


def exact_shares(rows: list[dict], law: str) -> np.ndarray:
    """The exact share [%] of `law` in each bin of f over the cases within the envelope (nan for an empty bin)."""
    shares = []
    for i in range(len(BINS) - 1):
        cell = [r["exact"] for r in within(rows) if r["law"] == law and bin_of(r["fraction"]) == i]
        shares.append(100.0 * np.mean(cell) if cell else np.nan)
    return np.array(shares)


def write_plot(path: Path, rows: list[dict], laws) -> Path:
    """An .rrd with one bar chart per law: the exact share [%] per bin of f (abscissa: bin centres)."""
    import rerun as rr
    import rerun.blueprint as rrb

    from testbed.recording.trace import recording_to

    centres = (np.array(BINS[:-1]) + np.array(BINS[1:])) / 2
    with recording_to(path, "steering-benchmark") as rec:
        for law in laws:
            rec.log(f"exact_share/{law}", rr.BarChart(np.nan_to_num(exact_shares(rows, law)), abscissa=centres,
                                                      widths=np.diff(BINS)), static=True)
        rec.send_blueprint(rrb.Blueprint(rrb.Grid(*[rrb.BarChartView(origin=f"exact_share/{law}",
                                                                     name=f"{law}: exact % per f") for law in laws])))
    return path


def main() -> None:
    global DURATION_S, RATE_MAX_DEG_S  # the script's constants, as every function reads them
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--array", default="rhombus", choices=list(ARRAYS), help="the CMG array")
    parser.add_argument("--slews", type=int, default=200)
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument("--sweep", type=int, default=0, help="Fibonacci directions of the Valk-style grid")
    parser.add_argument("--laws", default=",".join(LAWS))
    parser.add_argument("--markdown", action="store_true", help="print the docs' table (shares per bin) too")
    parser.add_argument("--duration-s", type=float, default=DURATION_S, help="the slews' duration T [s]")
    parser.add_argument("--rate-deg-s", type=float, default=RATE_MAX_DEG_S, help="the gimbal rate limit [deg/s]")
    parser.add_argument("--csv", type=Path, default=None)
    parser.add_argument("--rrd", type=Path, default=Path("runs/steering_benchmark.rrd"), help="the plot")
    args = parser.parse_args()
    laws = [law for law in args.laws.split(",") if law]
    unknown = [law for law in laws if law not in STEERING_LAWS and law != PLANNED]
    if unknown:
        parser.error(f"unknown law {unknown[0]!r}; choose from {', '.join(STEERING_LAWS)}")
    if args.slews < 0 or args.sweep < 0:
        parser.error("--slews and --sweep must be >= 0")
    if not (args.duration_s >= 1.0 and args.rate_deg_s > 0):  # nan fails too
        parser.error("--duration-s must be >= 1 s and --rate-deg-s > 0")
    DURATION_S, RATE_MAX_DEG_S = args.duration_s, args.rate_deg_s
    geo = geometry(args.array)
    refused = {law: reason for law in laws if (reason := refusal(law, geo))}
    flown = [law for law in laws if law not in refused]
    rows = [fly(law, case, geo) for case in cases(args.slews, args.seed, args.sweep, geo) for law in flown]
    print(table(rows, laws, refused))
    if args.markdown:
        print(markdown(rows, laws, refused, args.array, args.seed, args.slews, args.sweep))
    print(f"plot: {write_plot(args.rrd, rows, flown)}")
    if args.csv and rows:
        args.csv.parent.mkdir(parents=True, exist_ok=True)
        with args.csv.open("w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)


if __name__ == "__main__":
    main()
