"""docs/theory/steering.md, "Steering benchmark": every steering law on the same momentum paths,
binned by how much of the envelope each asks for.

The benchmark isolates the steering problem (Valk, Berry & Vallery 2018 call for such a sweep):
the rhombus cluster of reorient_near_singular (alpha = 54.74 deg, h = 1, beta'max = 30 deg/s) must
follow a rest-to-rest momentum path H_w(t) = r d 4 tau (1 - tau), tau = t / T (the cluster momentum
-I omega of an eigenaxis slew with SEEDS §004's cubic angle profile, T = 40 s), from a zero-momentum
start set, gimbal kinematics only (beta_{k+1} = beta_k + dt beta'_k, dt = 0.05 s, the control period;
no bus dynamics). Each step asks the law for the momentum still missing,
b_k = (H_w(t_{k+1}) - H(beta_k)) / dt (exact-torque feedback on the residual), with the step inputs
the allocator stage gives (testbed.steering.STEP_INPUTS) and its rcond (STAGE_RCOND).

Cases (reproducible by seed): d uniform on the sphere, the peak r = f E(d) with E(d) the envelope's
radius along d (ClusterGeometry.momentum_gauge) and f uniform from 0.2 h / E(d) to 0.95, the start
set one of START_SETS_DEG (the (45, -45, -45, 45) deg family). `--sweep N` adds the Valk-style grid:
N Fibonacci directions x every start set x FRACTIONS. Per law and bin of f: the share of cases with
exact torque (max |h J beta' - b| <= 1e-3 of the peak |b|) and sqrt(det J J^T) >= 0.05 throughout,
the peak gimbal rate, the final momentum error |H(beta_T)|/h, and the seconds with sqrt det < 0.1.
The usable fraction of the envelope of a law is the upper edge of the largest bin (and all below)
where it reaches 95 %. It prints the table and writes the exact shares as bar charts (`--rrd`).

    .venv/bin/python bench/steering_benchmark.py [--slews 200] [--seed 29] [--sweep 0] [--laws pinv,...]
                                                 [--csv runs/steering_benchmark.csv] [--rrd runs/steering_benchmark.rrd]
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

from testbed.steering import LAW_OPTIONS, STEERING_LAWS
from testbed.steering.planned_path import plan_gimbal_path
from testbed.steering.stage import STAGE_RCOND
from testbed.systems.cmg_rhombus.cluster import ClusterGeometry, rhombus_axes
from testbed.systems.cmg_rhombus.momentum_gauge import fibonacci_sphere

SEED = 29
ALPHA_DEG, RATE_MAX_DEG_S = 54.7356, 30.0
DURATION_S, DT_S = 40.0, 0.05
START_SETS_DEG = ((45.0, -45.0, -45.0, 45.0), (60.0, -60.0, -60.0, 60.0), (30.0, -30.0, -30.0, 30.0))
LOWEST_H, HIGHEST_FRACTION = 0.2, 0.95
FRACTIONS = (0.3, 0.5, 0.7, 0.8, 0.9)
BINS = (0.0, 0.3, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95)
EXACT, CLEAR, NEAR = 1e-3, 0.05, 0.1
LAWS = ("pinv", "sr", "gsr", "minimax", "minimax_avoid", "osr", "sda", "pga", "planned")
PLANNED = "planned"  # the plan of testbed.steering.planned_path, tracked by pga's null motion
PRESLEW_S = 5.0  # the rest before the slew (reorient_near_singular's start_s) the planned law may reconfigure in


def geometry() -> ClusterGeometry:
    """The benchmark's cluster: the rhombus of reorient_near_singular with h = 1."""
    e, g, _ = rhombus_axes(np.radians(ALPHA_DEG))
    return ClusterGeometry(g, e, np.ones(4), 1.0)


def envelope_radius(geo: ClusterGeometry, direction) -> float:
    """E(d) [h]: the largest |H| the cluster holds along the unit d (1 / gauge, momentum_gauge.py)."""
    gauge, _ = geo.momentum_gauge(np.asarray(direction, float)[None])
    return float(1.0 / gauge[0])


def cases(slews: int, seed: int = SEED, sweep: int = 0) -> list[dict]:
    """{direction, fraction, start, radius}: `slews` random cases, then the sweep grid (module doc)."""
    geo, rng, out = geometry(), np.random.default_rng(seed), []
    for _ in range(slews):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        radius = envelope_radius(geo, d)
        fraction = float(rng.uniform(LOWEST_H / radius, HIGHEST_FRACTION))
        out.append({"direction": d.tolist(), "fraction": fraction, "start": int(rng.integers(len(START_SETS_DEG))),
                    "radius": radius})
    for d in (fibonacci_sphere(sweep) if sweep else []):
        radius = envelope_radius(geo, d)
        out += [{"direction": d.tolist(), "fraction": f, "start": s, "radius": radius}
                for s in range(len(START_SETS_DEG)) for f in FRACTIONS]
    return out


def wanted_momentum(case: dict, t) -> np.ndarray:
    """H_w(t) = r d 4 tau (1 - tau) [h], (..., 3)."""
    tau = np.clip(np.asarray(t, float) / DURATION_S, 0.0, 1.0)
    return (case["fraction"] * case["radius"] * 4 * tau * (1 - tau))[..., None] * np.asarray(case["direction"])


def planned_path(case: dict, geo: ClusterGeometry, step_s: float = 0.1):
    """The plan of testbed.steering.planned_path for the case's H_w(t) = s(t) d (0.1 s steps), its reconfiguration
    at rest within PRESLEW_S at the rate limit; None when refused."""
    times = np.linspace(0.0, DURATION_S, int(round(DURATION_S / step_s)) + 1)
    rate_max = np.radians(RATE_MAX_DEG_S)
    return plan_gimbal_path(lambda beta: geo.momentum(beta) / geo.h, geo.unit_jacobian, np.radians(START_SETS_DEG[case["start"]]),
                            case["direction"], times, wanted_momentum(case, times) @ np.asarray(case["direction"]),
                            rate_max, reconfiguration_travel=rate_max * PRESLEW_S)


def fly(law: str, case: dict, geo: ClusterGeometry | None = None, duration_s: float = DURATION_S,
        dt: float = DT_S, history: bool = False) -> dict:
    """One law on one case (module doc): its figures, and with `history` the flown angles at every step
    ("angles", (steps + 1, 4)). `planned` plans the path before the slew (planned_path) and tracks it
    with pga's null motion towards the plan's next angles (gain 1/dt); a refused plan is not flown and
    counts as not exact."""
    geo = geo or geometry()
    rate_max = np.radians(RATE_MAX_DEG_S)
    beta = np.radians(START_SETS_DEG[case["start"]])
    plan = None
    if law == PLANNED:
        plan = planned_path(case, geo)
        if plan is None:
            return {"law": law, "fraction": case["fraction"], "peak_h": case["fraction"] * case["radius"],
                    "torque_error_rel": np.nan, "min_singularity_measure": np.nan, "peak_gimbal_rate_deg_s": 0.0,
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
    steps = int(round(duration_s / dt))
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
    return ({"angles": np.array(flown)} if history else {}) | {"law": law, "fraction": case["fraction"], "peak_h": case["fraction"] * case["radius"],
            "torque_error_rel": torque_error, "min_singularity_measure": lowest,
            "peak_gimbal_rate_deg_s": float(np.degrees(peak)),
            "final_momentum_error_h": float(np.linalg.norm(geo.momentum(beta) - wanted[-1])),
            "near_singular_s": dt * near, "exact": bool(torque_error <= EXACT and lowest >= CLEAR), "refused": False}


def bin_of(fraction: float) -> int:
    return int(np.searchsorted(BINS, fraction, side="right") - 1)


def table(rows: list[dict], laws) -> str:
    """Per law and bin of f: exact share, peak rate (max), final error (max), near-singular s (mean),
    plans refused (planned only)."""
    lines = [f"{'law':<14}{'bin of f':<12}{'n':>4}{'exact %':>9}{'peak deg/s':>12}{'final |dH|/h':>14}"
             f"{'near s':>8}{'refused':>9}"]
    for law in laws:
        mine = [r for r in rows if r["law"] == law]
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


def usable_fraction(rows: list[dict], law: str, share: float = 0.95) -> float:
    """Upper edge of the largest bin such that it and every bin below it reach `share` exact."""
    edge = BINS[0]
    for i, exact in enumerate(exact_shares(rows, law)):
        if exact < 100.0 * share:  # an empty bin (nan) does not stop the count
            break
        edge = BINS[i + 1]
    return edge


def exact_shares(rows: list[dict], law: str) -> np.ndarray:
    """The exact share [%] of `law` in each bin of f (nan for an empty bin)."""
    shares = []
    for i in range(len(BINS) - 1):
        cell = [r["exact"] for r in rows if r["law"] == law and bin_of(r["fraction"]) == i]
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
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--slews", type=int, default=200)
    parser.add_argument("--seed", type=int, default=SEED)
    parser.add_argument("--sweep", type=int, default=0, help="Fibonacci directions of the Valk-style grid")
    parser.add_argument("--laws", default=",".join(LAWS))
    parser.add_argument("--csv", type=Path, default=None)
    parser.add_argument("--rrd", type=Path, default=Path("runs/steering_benchmark.rrd"), help="the plot")
    args = parser.parse_args()
    laws = [law for law in args.laws.split(",") if law]
    unknown = [law for law in laws if law not in STEERING_LAWS and law != PLANNED]
    if unknown:
        parser.error(f"unknown law {unknown[0]!r}; choose from {', '.join(STEERING_LAWS)}")
    geo = geometry()
    rows = [fly(law, case, geo) for case in cases(args.slews, args.seed, args.sweep) for law in laws]
    print(table(rows, laws))
    print(f"plot: {write_plot(args.rrd, rows, laws)}")
    if args.csv:
        args.csv.parent.mkdir(parents=True, exist_ok=True)
        with args.csv.open("w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)


if __name__ == "__main__":
    main()
