"""Where one gyro stops observing a spinning CMG spacecraft with stored momentum (docs/theory/lebedev.md, its table),
and how the shipped stored-momentum scenario fares on random stored momenta.

    .venv/bin/python bench/lebedev_momentum_boundary.py [--inertia 1250,6900,7100] [--spin-deg-s 1] [--axis 1,1,1]
    .venv/bin/python bench/lebedev_momentum_boundary.py --cases 50 [--seed 16] [--workers 2] [--set KEY=VALUE ...]
    .venv/bin/python bench/lebedev_momentum_boundary.py --startup [--gimbals a,b,c,d ...]

Without --cases: for a spacecraft (default the flagship's locked inertia, the paper's gyro axis,
Omega = 1 deg/s) prints the three axial total momenta that are unobservable, the radius r* of
the ball of total momenta whose every state is observable at every instant, and the
information the measured-momentum observer holds at the end of a spin with total momentum |L|
at angle theta to the spin axis, relative to the rigid body's
(testbed.lebedev.momentum.end_state_information, no band: the circle itself); the
load-time check refuses below MIN_INFORMATION at the angles the idle start-up takes L to, give or
take CLOSED_LOOP_TILT_DEG.

With --cases N: runs `lebedev_spinup_cmg_momentum` N times from random gimbal angles (uniform in
[-180, 180) deg, seeded; the stored momentum is what they hold), with any further --set
overrides (another bus inertia, gyro axis), and prints one row per case (refused at load,
pass, or FAIL with the check that failed) and the counts. Alongside: the total momentum L,
the largest cluster momentum the final spin needs |H_end| = |L - I Omega e_z| (the cluster
holds at most 4 h = 300 N m s), `hold`: the largest share of what the cluster can hold that the
end circle asks for with L where the idle start-up leaves it (testbed.lebedev.end_momentum;
the load-time check refuses above 1 at every angle within CLOSED_LOOP_TILT_DEG of it), and the
steering's least singularity measure in the run.

With --startup: the start-up observer's error decay on the idle body (`startup_decay`).
"""

from __future__ import annotations

import argparse
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from testbed.errors import InputError
from testbed.lebedev.end_momentum import end_momentum_demand
from testbed.lebedev.momentum import (
    MIN_INFORMATION,
    axial_unobservable_momenta,
    end_state_information,
    idle_polar_angles,
    observable_momentum_radius,
)

SIZES = (10, 20, 40, 65, 100, 200)
ANGLES_DEG = (0, 30, 60, 90, 120, 150, 180)
SCENARIO = "lebedev_spinup_cmg_momentum"


def boundary(args) -> None:
    inertia = np.array([float(v) for v in args.inertia.split(",")])
    axis = np.array([float(v) for v in args.axis.split(",")])
    axis /= np.linalg.norm(axis)
    spin = np.radians(args.spin_deg_s)
    decay = 0.05   # the shipped poles' -0.1 1/s, halved (LebedevObserver.decay)
    radius, nearest = observable_momentum_radius(inertia, spin, axis)
    print(f"inertia {inertia.tolist()} kg m^2, Omega {args.spin_deg_s} deg/s, gyro axis {np.round(axis, 4).tolist()}")
    print("axial unobservable L3 [N m s]:", np.round(axial_unobservable_momenta(inertia, spin, axis), 2).tolist())
    print(f"r* = {radius:.2f} N m s (nearest unobservable L = {np.round(nearest, 2).tolist()})")
    print("| L [N m s] | " + " | ".join(f"{a} deg" for a in ANGLES_DEG) + " |")
    print("|---:|" + "---:|" * len(ANGLES_DEG))
    for size in SIZES:
        cells = []
        for angle in np.radians(ANGLES_DEG):
            L = size * np.array([np.sin(angle), 0.0, np.cos(angle)])
            info = end_state_information(inertia, spin, axis, L, decay)
            cells.append(f"{info:.2g}" + ("" if info >= MIN_INFORMATION else " x"))
        print(f"| {size} | " + " | ".join(cells) + " |")


def startup_decay(args) -> None:
    """The start-up observer alone on the idle body (Euler's equations of the body holding H(0),
    solved with DOP853; the observer sampled as in the run, y interpolated): its error every 50 s
    and the rate between the prints, for the shipped gimbal angles, the failing ones of issue 16
    and any given with --gimbals."""
    from scipy.integrate import solve_ivp

    from testbed.runner import prepare
    from testbed.scenario.loading import load_scenario

    cases = [("shipped", []), ("[30, -20, 10, 60]", ["model.gimbal_angles_deg=[30, -20, 10, 60]"])]
    cases += [(g, [f"model.gimbal_angles_deg=[{g}]"]) for g in args.gimbals]
    print("| gimbal angles [deg] | |H(0)| [N m s] | error [deg/s] at t = 0, 50, ..., 300 s | rate between [1/s] |")
    print("|---|---:|---|---|")
    for name, overrides in cases:
        scenario = load_scenario(SCENARIO, overrides + [f"pipeline.estimator.startup_s={args.horizon}"])
        plant, pipeline, _ = prepare(scenario)
        inertia = np.diag(plant.locked_inertia())
        held = plant.internal_momentum_body()
        period = scenario.sim.control_period_s
        times = np.arange(0.0, args.horizon + period / 2, period)
        truth = solve_ivp(lambda t, w: -np.cross(w, inertia * w + held) / inertia, (0.0, times[-1]),
                          np.radians(scenario.initial.omega_deg_s), method="DOP853", rtol=1e-11, atol=1e-15,
                          t_eval=times).y.T
        observer = pipeline.estimator.observer   # started with H(0) by the stage
        errors = [np.linalg.norm(truth[0] - observer.omega_estimate())]
        for k in range(1, times.size):
            observer.startup_step(observer.C @ truth[k - 1], period, observer.C @ truth[k], held)
            if k % round(50.0 / period) == 0:
                errors.append(np.linalg.norm(truth[k] - observer.omega_estimate()))
        rates = [np.log(a / b) / 50.0 for a, b in zip(errors, errors[1:])]
        print(f"| {name} | {np.linalg.norm(held):.1f} | {' / '.join(f'{np.degrees(e):.2g}' for e in errors)} | "
              f"{' / '.join(f'{r:.3f}' for r in rates)} |")


def run_case(job):
    """(index, verdict, detail, figures) of one random stored momentum."""
    from testbed.runner import prepare, run_scenario
    from testbed.scenario.loading import load_scenario

    index, angles, overrides = job
    assignments = [f"model.gimbal_angles_deg=[{', '.join(f'{a:.6f}' for a in angles)}]", *overrides]
    try:
        scenario = load_scenario(SCENARIO, assignments)
        plant, pipeline, _ = prepare(scenario)
    except InputError as exc:
        return index, "refused", str(exc), {}
    inertia = plant.locked_inertia()
    L = inertia @ np.radians(scenario.initial.omega_deg_s) + plant.internal_momentum_body()
    spin = pipeline.law.target[2]
    figures = {"|L|": float(np.linalg.norm(L)),
               "theta_deg": float(np.degrees(np.arccos(L[2] / np.linalg.norm(L)))),
               "|H_end|": float(np.hypot(np.hypot(L[0], L[1]), L[2] - inertia[2, 2] * spin))}
    held = plant.internal_momentum_body()
    polar = idle_polar_angles(np.diag(inertia), held, np.radians(scenario.initial.omega_deg_s),
                              scenario.stages["estimator"][1].startup_s)[-1]
    (share, _, _, _), = end_momentum_demand(plant.description().momentum_gauge, np.diag(inertia), spin,
                                            float(np.linalg.norm(L)), [polar])
    figures["hold"] = share
    run = run_scenario(scenario, None)
    m = run.metrics
    figures |= {"closing": m["estimation_error_at_closing_deg_s"], "est_final": m["estimation_error_final_deg_s"],
                "spin_final": m["spin_error_final_deg_s"], "min_sing": m["min_singularity_measure"]}
    failed = [c["name"] for c in run.checks if not c["passed"]]
    if run.status != "ok":
        failed.insert(0, f"status {run.status}: {run.error}")
    return index, "FAIL" if failed else "pass", ", ".join(failed), figures


def cases(args) -> None:
    rng = np.random.default_rng(args.seed)
    jobs = [(i, rng.uniform(-180.0, 180.0, 4), args.set) for i in range(args.cases)]
    counts = {"pass": 0, "refused": 0, "FAIL": 0}
    print(f"{SCENARIO} from {args.cases} random gimbal angles (seed {args.seed}), overrides {args.set}")
    print("case verdict   |L|  theta  |H_end|  hold closing_err est_final spin_final min_sing  detail")
    with ProcessPoolExecutor(args.workers) as pool:
        for index, verdict, detail, f in pool.map(run_case, jobs):
            counts[verdict] += 1
            row = (f"{f['|L|']:5.0f} {f['theta_deg']:6.1f} {f['|H_end|']:6.0f} {f['hold']:5.3f}   {f['closing']:9.2g}"
                   f" {f['est_final']:9.2g} {f['spin_final']:9.2g} {f['min_sing']:8.2g}" if "closing" in f else " " * 70)
            print(f"{index:4d} {verdict:8s}{row}  {detail}", flush=True)
    print(f"pass {counts['pass']}, refused {counts['refused']}, accepted and failing {counts['FAIL']} "
          f"(of {args.cases})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--inertia", default="1250,6900,7100")
    parser.add_argument("--spin-deg-s", type=float, default=1.0)
    parser.add_argument("--axis", default="1,1,1")
    parser.add_argument("--cases", type=int, default=0, help="run the scenario on this many random stored momenta")
    parser.add_argument("--seed", type=int, default=16)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--set", action="append", default=[], help="a further scenario override (with --cases)")
    parser.add_argument("--startup", action="store_true", help="the start-up observer's error decay (table)")
    parser.add_argument("--horizon", type=float, default=300.0, help="with --startup: how long [s]")
    parser.add_argument("--gimbals", action="append", default=[], help="with --startup: further gimbal angles a,b,c,d")
    args = parser.parse_args()
    if args.startup:
        startup_decay(args)
    elif args.cases:
        cases(args)
    else:
        boundary(args)


if __name__ == "__main__":
    main()
