"""The 600 s `cmg_open_loop` run against Basilisk 2.12 (the `bsk` package) on the same
spacecraft, at equal accuracy, side by side (issue 41's goal: at least 8x Basilisk's speed).

The spacecraft Basilisk flies is read from the testbed's compiled model (`spacecraft`): the
bus's mass, CoM and inertia, and per unit the gimbal's place, axes, mass and inertia, the
rotor's mass and inertias, the initial gimbal angles, rotor speeds, bus attitude and body rate
after the plant's own initialisation. Basilisk builds a rigid hub with four balanced
`VSCMGStateEffector` units from it, its `vscmgGimbalRateServo` (K_gammaDot = `--gain`) fed by
`simpleNav`, and a Python module that writes the scenario's sinusoidal gimbal-rate command:
command, servo and motor torques held over the scenario's control period (0.01 s) as in the
testbed, the dynamics stepped with RK4 at `--bsk-dt`.

Accuracy (`--accuracy DT ...`: the testbed at 0.01 s and Basilisk at each DT, no timing), on
each simulator's own 600 s run, its histories sampled every control tick:
  drift   max |L(t) - L(0)| / max(|L(0)|, sum of rotor momenta), L the inertial angular momentum
          about the system CoM (the testbed's momentum_drift_rel);
  omega   max |w(t) - w_ref(t)| every 0.1 s [rad/s], w_ref the testbed's reduced model driven by
          the gimbal angles, rates and rotor speeds of that run (`own_history_error`: the same
          reference code and mass properties for both).
Basilisk's step is chosen so that both are no worse than the testbed's at dt 0.01 s. The
gimbal-rate tracking of the held command is printed beside them; it is the servos', not part
of the criterion (docs/validation.md, "Against Basilisk").

Speed: whole processes, alternated (testbed, Basilisk, testbed, ...), `--rounds` pairs after one
uncounted pair. The testbed side is `python -c "testbed.run('cmg_open_loop', ...)"` with no
analytic reference and no checks (the reduced-model oracle is validation, not simulation) and
no .rrd file; the Basilisk side is this file's worker, which builds and runs the spacecraft and
records the body rate and momentum every 0.1 s (the testbed keeps its trace in memory too).
Printed: each side's best and median wall time and the ratios (Basilisk over testbed), and
the testbed's physics floor, bare `mj_step` over the same steps (in-process time in a fresh
process, `bare_physics`), with Basilisk's time over it: the most any per-tick work in Python
could buy.

Basilisk lives in its own venv (`--venv`, default runs/bsk-venv, made on first use with
`pip install bsk==2.12.0`); it is never a dependency of the project.

    .venv/bin/python bench/bench_basilisk.py [--rounds N] [--bsk-dt S] [--gain K] [--accuracy DT ...] [--venv DIR]
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SCENARIO = "cmg_open_loop"
BSK_VERSION = "2.12.0"
SAMPLE_PERIOD_S = 0.1  # both sides record the body rate and momentum this often
TIMEOUT_S = 1800.0  # one process; a hang ends the benchmark
# the testbed's side: the run alone (no oracle reference, no checks, no file)
TESTBED_OVERRIDES = ["reference=", "checks={}"]


# ---------------------------------------------------------------- the spacecraft, from the testbed


def spacecraft(overrides=()) -> dict:
    """The testbed's cmg_open_loop spacecraft as plain numbers for Basilisk (SI units, bus
    frame): bus mass [kg], CoM [m] and inertia about it [kg m^2]; per unit the gimbal's origin
    [m], axes gs0 (spin at gamma = 0), gt0 = gg x gs0 and gg (gimbal axis), the gimbal's and the
    rotor's masses [kg] and inertias about their CoMs in (gs, gt, gg) axes at gamma = 0, the
    initial gimbal angle [rad] and rotor speed relative to the gimbal [rad/s]; the initial bus
    attitude (MRP, inertial to body) and body rate [rad/s]; the gimbal-rate profile
    (offset, amplitude [rad/s], angular frequency [rad/s], phase [rad]); the control period and
    duration [s]. Read from the compiled model and its data after the plant's initialisation."""
    import numpy as np

    import testbed
    from testbed.math.quaternion import quat_to_matrix
    from testbed.systems import registry as systems_registry
    from testbed.systems.cmg_cluster.cluster import unit_count, unit_names

    scenario = testbed.load(SCENARIO, list(overrides))
    plant = systems_registry.make_plant(scenario)
    plant.initialise(scenario.initial)
    model, data = plant.model, plant.data

    def inertia_about_com(body) -> np.ndarray:  # body frame
        principal = quat_to_matrix(model.body_iquat[body])
        return principal @ np.diag(model.body_inertia[body]) @ principal.T

    bus = model.body("bus").id
    units = []
    for gimbal_name, rotor_name in zip(*unit_names(unit_count(model))):
        gimbal, rotor = model.body(gimbal_name).id, model.body(rotor_name).id
        if np.any(model.body_ipos[gimbal]) or np.any(model.body_pos[rotor]) or np.any(model.body_ipos[rotor]):
            raise ValueError("Basilisk's balanced VSCMG puts the gimbal's and rotor's CoMs at the gimbal origin")
        to_bus = quat_to_matrix(model.body_quat[gimbal])  # gimbal frame at beta = 0 -> bus frame
        rotor_to_gimbal = quat_to_matrix(model.body_quat[rotor])
        gg = to_bus @ model.jnt_axis[model.joint(gimbal_name).id]
        gs0 = to_bus @ rotor_to_gimbal @ model.jnt_axis[model.joint(rotor_name).id]
        gt0 = np.cross(gg, gs0)
        axes = np.column_stack([gs0, gt0, gg])  # G frame -> bus frame
        gimbal_g = axes.T @ to_bus @ inertia_about_com(gimbal) @ to_bus.T @ axes
        rotor_g = axes.T @ to_bus @ rotor_to_gimbal @ inertia_about_com(rotor) @ rotor_to_gimbal.T @ to_bus.T @ axes
        units.append({
            "position": model.body_pos[gimbal].tolist(), "gs0": gs0.tolist(), "gt0": gt0.tolist(), "gg": gg.tolist(),
            "gimbal_mass": float(model.body_mass[gimbal]), "gimbal_inertia": gimbal_g.tolist(),
            "rotor_mass": float(model.body_mass[rotor]), "rotor_inertia": rotor_g.tolist(),
            "gamma0": float(data.qpos[model.jnt_qposadr[model.joint(gimbal_name).id]]),
            "gamma_rate0": float(data.qvel[model.jnt_dofadr[model.joint(gimbal_name).id]]),
            "omega0": float(data.qvel[model.jnt_dofadr[model.joint(rotor_name).id]]),
        })
    free = model.jnt_dofadr[model.joint("bus").id]
    quat = data.qpos[model.jnt_qposadr[model.joint("bus").id] + 3:][:4]  # (w, x, y, z), body -> world
    mrp = (-quat[1:] / (1.0 + quat[0])) if quat[0] >= 0 else (quat[1:] / (1.0 - quat[0]))  # world -> body
    profile = scenario.stages["allocator"][1]
    terms = list(zip(profile.offset, profile.amplitude, (2 * np.pi * np.array(profile.frequency_hz)).tolist(),
                     np.deg2rad(profile.phase_deg).tolist()))
    return {"bus_mass": float(model.body_mass[bus]), "bus_com": model.body_ipos[bus].tolist(),
            "bus_inertia": inertia_about_com(bus).tolist(), "units": units,
            "sigma0": mrp.tolist(), "omega0": data.qvel[free + 3:free + 6].tolist(),
            "profile": terms, "control_period": scenario.sim.control_period_s,
            "duration": scenario.sim.duration_s}


def locked_inertia(craft: dict, angles) -> list:
    """The spacecraft's inertia about its CoM, bus axes, joints locked at gimbal `angles` [rad],
    summed from `spacecraft`'s numbers as Basilisk sums its hub and balanced VSCMGs [kg m^2]."""
    import numpy as np

    mass = craft["bus_mass"] + sum(u["gimbal_mass"] + u["rotor_mass"] for u in craft["units"])
    points = [(craft["bus_mass"], np.array(craft["bus_com"]))] + [
        (u["gimbal_mass"] + u["rotor_mass"], np.array(u["position"])) for u in craft["units"]]
    com = sum(m * r for m, r in points) / mass
    total = np.array(craft["bus_inertia"])
    for u, gamma in zip(craft["units"], angles):
        turn = np.array([[math.cos(gamma), -math.sin(gamma), 0.0], [math.sin(gamma), math.cos(gamma), 0.0],
                         [0.0, 0.0, 1.0]])  # about gg, in G axes
        axes = np.column_stack([u["gs0"], u["gt0"], u["gg"]]) @ turn
        total = total + axes @ (np.array(u["gimbal_inertia"]) + np.array(u["rotor_inertia"])) @ axes.T
    for m, r in points:
        d = r - com
        total = total + m * (d @ d * np.eye(3) - np.outer(d, d))
    return total.tolist()


# ---------------------------------------------------------------- the Basilisk side (its own venv)


def basilisk_run(craft: dict, dt: float, gain: float, duration: float, sample: float) -> dict:
    """Build the spacecraft in Basilisk, run it `duration` [s] with RK4 at `dt`, the gimbal-rate
    command, servo and motor torques held over the control period; the body rate [rad/s],
    inertial angular momentum about the CoM [N m s], gimbal angles [rad] and rates [rad/s] and
    rotor speeds [rad/s] every `sample` [s], and the build and run wall times [s]."""
    started = time.perf_counter()
    from Basilisk.architecture import messaging, sysModel
    from Basilisk.fswAlgorithms import vscmgGimbalRateServo
    from Basilisk.simulation import simpleNav, spacecraft as bsk_spacecraft, vscmgStateEffector
    from Basilisk.utilities import SimulationBaseClass, macros

    sim = SimulationBaseClass.SimBaseClass()
    process = sim.CreateNewProcess("process")
    period = craft["control_period"]
    # the command and servo before the dynamics at a shared time (priority: higher runs first)
    process.addTask(sim.CreateNewTask("fsw", macros.sec2nano(period)), 20)
    process.addTask(sim.CreateNewTask("dynamics", macros.sec2nano(dt)), 10)

    craft_bsk = bsk_spacecraft.Spacecraft()
    craft_bsk.hub.mHub = craft["bus_mass"]
    craft_bsk.hub.r_BcB_B = [[x] for x in craft["bus_com"]]
    craft_bsk.hub.IHubPntBc_B = craft["bus_inertia"]
    craft_bsk.hub.sigma_BNInit = [[x] for x in craft["sigma0"]]
    craft_bsk.hub.omega_BN_BInit = [[x] for x in craft["omega0"]]

    cluster = vscmgStateEffector.VSCMGStateEffector()
    config = messaging.VSCMGArrayConfigMsgPayload()
    lists = {name: [] for name in ("Gs0Matrix_B", "Gt0Matrix_B", "GgMatrix_B", "JsList", "JtList", "JgList",
                                   "IwsList", "Omega0List", "gamma0List", "gammaDot0List")}
    for u in craft["units"]:
        unit = messaging.VSCMGConfigMsgPayload()
        unit.VSCMGModel = 0  # balanced wheels
        unit.rGB_B = [[x] for x in u["position"]]
        unit.gsHat0_B, unit.gtHat0_B, unit.ggHat_B = ([[x] for x in u[k]] for k in ("gs0", "gt0", "gg"))
        gi, ri = u["gimbal_inertia"], u["rotor_inertia"]
        unit.IG1, unit.IG2, unit.IG3 = gi[0][0], gi[1][1], gi[2][2]
        unit.IG12, unit.IG13, unit.IG23 = gi[0][1], gi[0][2], gi[1][2]
        unit.IW1, unit.IW2, unit.IW3, unit.IW13 = ri[0][0], ri[1][1], ri[2][2], ri[0][2]
        unit.massG, unit.massW = u["gimbal_mass"], u["rotor_mass"]
        unit.rGcG_G = [[0.0], [0.0], [0.0]]
        unit.U_s = unit.U_d = unit.l = unit.L = 0.0
        unit.Omega, unit.gamma, unit.gammaDot = u["omega0"], u["gamma0"], u["gamma_rate0"]
        unit.u_s_max = unit.u_g_max = -1.0  # no torque limits
        unit.u_s_f = unit.u_g_f = 0.0  # no friction
        unit.u_s_min = unit.u_g_min = -1.0
        unit.wheelLinearFrictionRatio = unit.gimbalLinearFrictionRatio = -1.0
        unit.Omega_max, unit.gammaDot_max = -1.0, -1.0
        cluster.AddVSCMG(unit)
        for name, value in (("Gs0Matrix_B", u["gs0"]), ("Gt0Matrix_B", u["gt0"]), ("GgMatrix_B", u["gg"])):
            lists[name].extend(value)
        lists["JsList"].append(gi[0][0] + ri[0][0])
        lists["JtList"].append(gi[1][1] + ri[1][1])
        lists["JgList"].append(gi[2][2] + ri[2][2])
        lists["IwsList"].append(ri[0][0])
        lists["Omega0List"].append(u["omega0"])
        lists["gamma0List"].append(u["gamma0"])
        lists["gammaDot0List"].append(u["gamma_rate0"])
    for name, values in lists.items():
        setattr(config, name, values)
    config.numVSCMG = len(craft["units"])
    config_msg = messaging.VSCMGArrayConfigMsg().write(config)
    craft_bsk.addStateEffector(cluster)

    class RateProfile(sysModel.SysModel):
        """The scenario's gimbal-rate command, offset + amplitude sin(w t + phase)."""

        def __init__(self, terms):
            super().__init__()
            self.terms = terms
            self.refOutMsg = messaging.VSCMGRefStatesMsg()
            self.payload = messaging.VSCMGRefStatesMsgPayload()

        def UpdateState(self, now_ns):
            t = now_ns * 1e-9
            self.payload.gimbalRates = [o + a * math.sin(w * t + p) for o, a, w, p in self.terms]
            self.refOutMsg.write(self.payload, now_ns, self.moduleID)

    profile = RateProfile(craft["profile"])
    navigation = simpleNav.SimpleNav()
    navigation.scStateInMsg.subscribeTo(craft_bsk.scStateOutMsg)
    servo = vscmgGimbalRateServo.VscmgGimbalRateServo()
    servo.setK_gammaDot(gain)
    servo.vsmcgParamsInMsg.subscribeTo(config_msg)
    servo.vscmgRefStatesInMsg.subscribeTo(profile.refOutMsg)
    servo.attInMsg.subscribeTo(navigation.attOutMsg)
    servo.speedsInMsg.subscribeTo(cluster.speedOutMsg)
    cluster.cmdsInMsg.subscribeTo(servo.cmdsOutMsg)
    for module, priority in ((profile, 30), (navigation, 20), (servo, 10)):
        sim.AddModelToTask("fsw", module, priority)
    # the spacecraft integrates to t_k first, then the cluster takes the servo's torque for
    # [t_k, t_k+1] and writes its gimbal states at t_k (in the other order its speed message
    # holds the states one step old), then the recorders
    sim.AddModelToTask("dynamics", craft_bsk, 20)
    sim.AddModelToTask("dynamics", cluster, 10)
    every = macros.sec2nano(sample)
    states = craft_bsk.scStateOutMsg.recorder(every)
    speeds = cluster.speedOutMsg.recorder(every)
    momentum = craft_bsk.logger(["totRotAngMomPntC_N"], every)
    for recorder in (states, speeds, momentum):
        sim.AddModelToTask("dynamics", recorder)
    sim.InitializeSimulation()
    built = time.perf_counter()
    sim.ConfigureStopTime(macros.sec2nano(duration))
    sim.ExecuteSimulation()
    ran = time.perf_counter()
    count = len(craft["units"])
    return {"t": (states.times() * 1e-9).tolist(), "omega": states.omega_BN_B.tolist(),
            "momentum": momentum.totRotAngMomPntC_N.tolist(), "momentum_t": (momentum.times() * 1e-9).tolist(),
            "gimbal_angle": speeds.gimbalAngles[:, :count].tolist(),
            "gimbal_rate": speeds.gimbalRates[:, :count].tolist(),
            "rotor_rate": speeds.wheelSpeeds[:, :count].tolist(), "build_s": built - started,
            "run_s": ran - built}


def ensure_venv(venv: Path) -> Path:
    """The Basilisk venv's python, the venv made (pip install bsk) when absent."""
    python = venv / "bin" / "python"
    if not python.exists():
        subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
        subprocess.run([str(python), "-m", "pip", "install", "--quiet", f"bsk=={BSK_VERSION}"], check=True)
    found = subprocess.run([str(python), "-c", "from importlib.metadata import version; print(version('bsk'))"],
                           capture_output=True, text=True, check=True).stdout.strip()
    if found != BSK_VERSION:
        raise SystemExit(f"{venv}: bsk {found}, expected {BSK_VERSION}")
    return python


def in_basilisk(python: Path, craft_file: Path, dt: float, gain: float, duration: float, out: Path,
                sample: float = SAMPLE_PERIOD_S) -> float:
    """Run the worker in the Basilisk venv; its whole-process wall time [s]."""
    command = [str(python), str(Path(__file__).resolve()), "--worker", str(craft_file), "--bsk-dt", repr(dt),
               "--gain", repr(gain), "--duration", repr(duration), "--sample", repr(sample), "--worker-out", str(out)]
    started = time.perf_counter()
    subprocess.run(command, check=True, timeout=TIMEOUT_S, stdout=subprocess.DEVNULL)
    return time.perf_counter() - started


def in_testbed(overrides) -> float:
    """`testbed.run` of the scenario in a fresh process of this venv; its whole-process wall time [s]."""
    code = (f"import testbed; r = testbed.run({SCENARIO!r}, overrides={list(overrides)!r}); "
            "assert r.status == 'ok', r.status")
    started = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], check=True, timeout=TIMEOUT_S, cwd=REPO)
    return time.perf_counter() - started


def bare_physics(duration: float) -> float:
    """The physics floor: wall time [s] of bare `mj_step` over the run's steps on the testbed's
    model, in a fresh process (built and initialised as the run builds it; no stages)."""
    code = ("import time, mujoco, testbed\n"
            "from testbed.systems import registry\n"
            f"s = testbed.load({SCENARIO!r}, {TESTBED_OVERRIDES!r})\n"
            "p = registry.make_plant(s); p.initialise(s.initial)\n"
            f"n = round({duration!r} / s.sim.dt_s)\n"
            "t = time.perf_counter(); mujoco.mj_step(p.model, p.data, nstep=n); print(time.perf_counter() - t)")
    out = subprocess.run([sys.executable, "-c", code], check=True, timeout=TIMEOUT_S, cwd=REPO,
                         capture_output=True, text=True).stdout
    return float(out.split()[-1])


# ---------------------------------------------------------------- accuracy


def drift(momentum, scale: float) -> float:
    import numpy as np

    momentum = np.asarray(momentum)
    return float(np.linalg.norm(momentum - momentum[0], axis=1).max() / max(np.linalg.norm(momentum[0]), scale))


def own_history_error(run: dict, period: float) -> float:
    """max |w(t) - w_ref(t)| [rad/s] over the samples every `period`, w_ref the testbed's reduced
    model (reduced_model.py: the rigid bus and the gimbals and rotors as they moved in this run,
    integrated with DOP853 at rtol 1e-12) on the testbed's mass properties, which both simulators
    share (`locked_inertia`)."""
    import numpy as np

    import testbed
    from testbed.systems import registry as systems_registry
    from testbed.systems.cmg_cluster.reduced_model import reduced_cmg_omega

    plant = systems_registry.make_plant(testbed.load(SCENARIO))
    t = np.asarray(run["t"])
    every = max(1, round(period / (t[1] - t[0])))
    omega = reduced_cmg_omega(plant.model, t, np.asarray(run["gimbal_angle"]), np.asarray(run["gimbal_rate"]),
                              np.asarray(run["rotor_rate"]), np.asarray(run["omega"][0]), t[::every])
    return float(np.linalg.norm(omega - np.asarray(run["omega"])[::every], axis=1).max())


def tracking(run: dict, craft: dict) -> float:
    """max |b'(t_k+1) - c_k| / max amplitude over the ticks after the first second: how well the
    gimbal rates follow the command held over each control period."""
    import numpy as np

    t, rate = np.asarray(run["t"]), np.asarray(run["gimbal_rate"])
    held = np.array([[o + a * math.sin(w * s + p) for o, a, w, p in craft["profile"]]
                     for s in np.round((t - craft["control_period"]) / craft["control_period"]) * craft["control_period"]])
    late = t >= 1.0
    return float(np.abs(rate[late] - held[late]).max() / max(abs(a) for _, a, _, _ in craft["profile"]))


def testbed_trace(dt: float, duration: float, sample: float) -> dict:
    import testbed

    result = testbed.run(SCENARIO, overrides=TESTBED_OVERRIDES + [f"sim.dt_s={dt!r}", f"sim.duration_s={duration!r}",
                                                                 f"sim.trace_period_s={sample!r}"])
    names = {"omega": "truth/omega", "momentum": "truth/angular_momentum_world", "gimbal_angle": "truth/gimbal_angle",
             "gimbal_rate": "truth/gimbal_rate", "rotor_rate": "truth/rotor_rate"}
    run = {key: result.trace[name][1].tolist() for key, name in names.items()}
    run["t"] = result.trace["truth/omega"][0].tolist()
    return run


def accuracy(python: Path, craft: dict, craft_file: Path, dts, gain: float, duration: float, work: Path) -> None:
    """Print each simulator's momentum drift, its body-rate error against the reduced model
    driven by its own gimbal history, and (not part of the criterion) its gimbal-rate tracking."""
    scale = sum(u["rotor_inertia"][0][0] * abs(u["omega0"]) for u in craft["units"])
    sample = craft["control_period"]  # the histories the reduced model interpolates: every tick
    runs = [("testbed", 0.01, testbed_trace(0.01, duration, sample))]
    for dt in dts:
        out = work / "accuracy.json"
        in_basilisk(python, craft_file, dt, gain, duration, out, sample)
        runs.append(("basilisk", dt, json.loads(out.read_text())))
    for name, dt, run in runs:
        print(f"{name:9s} dt {dt:<7g} drift {drift(run['momentum'], scale):.3g}   body-rate error "
              f"{own_history_error(run, SAMPLE_PERIOD_S):.3g} rad/s   gimbal-rate tracking {tracking(run, craft):.2g}",
              flush=True)


# ---------------------------------------------------------------- main


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=3, help="timed pairs after one uncounted pair")
    parser.add_argument("--bsk-dt", type=float, default=0.01, help="Basilisk's RK4 step [s]")
    parser.add_argument("--gain", type=float, default=50.0, help="Basilisk's servo gain K_gammaDot [1/s]")
    parser.add_argument("--duration", type=float, default=None, help="simulated seconds (default: the scenario's)")
    parser.add_argument("--accuracy", nargs="*", type=float, metavar="DT",
                        help="measure the accuracy of the testbed at 0.01 s and Basilisk at these steps, no timing")
    parser.add_argument("--venv", type=Path, default=REPO / "runs" / "bsk-venv", help="Basilisk's own venv")
    parser.add_argument("--worker", type=Path, help=argparse.SUPPRESS)  # in the Basilisk venv: the craft file
    parser.add_argument("--worker-out", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--sample", type=float, default=SAMPLE_PERIOD_S, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker is not None:
        craft = json.loads(args.worker.read_text())
        result = basilisk_run(craft, args.bsk_dt, args.gain, args.duration, args.sample)
        args.worker_out.write_text(json.dumps(result))
        return
    python = ensure_venv(args.venv)
    craft = spacecraft()
    duration = craft["duration"] if args.duration is None else args.duration
    with tempfile.TemporaryDirectory() as work:
        work = Path(work)
        craft_file = work / "craft.json"
        craft_file.write_text(json.dumps(craft))
        if args.accuracy is not None:
            accuracy(python, craft, craft_file, args.accuracy or [args.bsk_dt], args.gain, duration, work)
            return
        overrides = TESTBED_OVERRIDES + [f"sim.duration_s={duration!r}"]
        ours, theirs, floors = [], [], []
        for round_ in range(args.rounds + 1):  # the first round warms the file caches, not counted
            a = in_testbed(overrides)
            b = in_basilisk(python, craft_file, args.bsk_dt, args.gain, duration, work / "bsk.json")
            c = bare_physics(duration)
            if round_:
                ours.append(a)
                theirs.append(b)
                floors.append(c)
            print(f"round {round_}: testbed {a:.2f} s, basilisk {b:.2f} s, bare mj_step {c:.2f} s"
                  f"{'' if round_ else ' (not counted)'}", flush=True)
    ratios = [b / a for a, b in zip(ours, theirs)]
    floor_ratios = [b / c for b, c in zip(theirs, floors)]
    print(f"{SCENARIO}, {duration:g} s simulated, whole processes, {args.rounds} rounds alternated; "
          f"Basilisk {BSK_VERSION} at dt {args.bsk_dt:g} s, the testbed at the scenario's 0.01 s")
    print(f"testbed  best {min(ours):.2f} s  median {statistics.median(ours):.2f} s")
    print(f"basilisk best {min(theirs):.2f} s  median {statistics.median(theirs):.2f} s")
    print(f"speed ratio (Basilisk / testbed): best-of {min(theirs) / min(ours):.2f}x, "
          f"median of rounds {statistics.median(ratios):.2f}x")
    print(f"bare mj_step (the testbed's physics floor) best {min(floors):.2f} s: Basilisk over it "
          f"best-of {min(theirs) / min(floors):.2f}x, median of rounds {statistics.median(floor_ratios):.2f}x")


if __name__ == "__main__":
    main()
