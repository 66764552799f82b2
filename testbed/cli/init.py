"""`testbed init DIR`: start your own controller from a template that runs as it is.

    testbed init mysat
    testbed run mysat/my_scenario.yaml

Writes DIR/my_scenario.yaml (a commented scenario) and DIR/my_controller.py (a plug-in law
stage `my.controller` with its own parameters), then prints the next steps. DIR is created if
needed; a DIR that exists and is not an empty folder is refused (exit 2), and no file is ever
overwritten. The two templates are checked by tests/test_examples.py: the scenario's checks
pass unedited.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

from testbed.cli.commands import EXIT_OK, command, reported
from testbed.errors import InputError, quoted
from testbed.recording.output_paths import check_creatable

SCENARIO_FILE, CONTROLLER_FILE = "my_scenario.yaml", "my_controller.py"

SCENARIO_TEMPLATE = """\
# One experiment: the spacecraft, its initial state, the control pipeline and the checks.
# Run it with:   testbed run {scenario_path}
# Units are in the key names (_s, _deg, _deg_s, _kg_m2, ...); quaternions are (w, x, y, z),
# body to world. Every key is listed in docs/scenarios.md, section "Scenario files". Any key can be
# changed for one run without editing this file: --set pipeline.law.natural_frequency_rad_s=0.1
# This file is read as data (YAML safe loader); only the plug-ins below run code.

name: my_scenario
description: my controller turns a tumbling satellite to a target attitude and holds it there

plugins: [my_controller.py]        # Python files (relative to this file) that register stages

model:                             # the spacecraft: a rigid bus with ideal 3-axis torquers
  system: satellite                # `testbed list` shows the scenarios of the other systems
  inertia_kg_m2: [800, 1000, 1200] # principal inertia, body axes

initial:
  omega_deg_s: [0.5, -0.3, 0.4]    # body rate at t = 0
  quat: [1, 0, 0, 0]               # attitude at t = 0

sim:
  duration_s: 120
  dt_s: 0.01                       # physics step (MuJoCo, RK4)
  control_period_s: 0.05           # the pipeline runs every 0.05 s; its command is held between
  trace_period_s: 0.1              # how often the trace (runs/my_scenario.rrd) samples signals

pipeline:                          # sensor -> estimator -> law -> allocator, each chosen by type
  sensor: {{type: ideal_attitude}}   # true attitude and rate (add attitude_noise_rad, rate_noise_rad_s, seed)
  estimator: {{type: attitude}}      # passes them on: estimate["quat"], estimate["omega"]
  law:
    type: my.controller            # your law, in my_controller.py; the other keys are its parameters
    target_quat: [0.9659258262890683, 0.25881904510252074, 0, 0]   # 30 deg about body x
    natural_frequency_rad_s: 0.2
    damping_ratio: 0.9
  allocator: {{type: ideal_torque}}  # applies the law's torque to the bus exactly

checks:                            # bounds on the run's metrics: exit 0 only if all hold
  final_omega_rad_s: {{max: 1e-4}}                 # |w| at the end [rad/s]
  my_final_attitude_error_deg: {{max: 0.01}}       # a metric defined in my_controller.py
"""

CONTROLLER_TEMPLATE = '''\
"""My attitude controller: a plug-in law for the testbed, named "my.controller".

my_scenario.yaml loads this file (`plugins: [my_controller.py]`) and picks the law with
`law: {type: my.controller, ...}`. Edit `torque` below, then run
    testbed run my_scenario.yaml
A plug-in is ordinary Python that runs with your rights; it may import anything installed.
A stage name is registered once per process: a second controller needs a name of its own.
"""

from dataclasses import dataclass

import numpy as np

import testbed


@dataclass(kw_only=True)
class MyControllerParams:
    """The law's keys in my_scenario.yaml (besides `type`): defaults, bounds, units in the names.
    A key that is not declared here, a wrong type or a value out of bounds is refused before the run."""

    target_quat: list[float] = testbed.param([1.0, 0.0, 0.0, 0.0], length=4,
                                             doc="attitude to reach and hold (w, x, y, z), body to world")
    natural_frequency_rad_s: float = testbed.param(0.2, gt=0, doc="how fast the attitude error decays")
    damping_ratio: float = testbed.param(0.9, gt=0, doc="1: no overshoot; smaller: faster, with overshoot")

    def validate(self, path):
        if abs(np.linalg.norm(self.target_quat) - 1.0) > 1e-6:
            raise testbed.InputError(f"{path}.target_quat", "must be a unit quaternion")


@testbed.stage("law", "my.controller", MyControllerParams)
class MyController:
    outputs = ("torque", "attitude_error")  # the keys torque() returns

    def __init__(self, params, ctx):
        """Built once before the run. `params`: a MyControllerParams from the scenario.
        `ctx` (testbed.StageContext) holds design data, never the running truth:
        ctx.inertia (3, 3) [kg m^2] body axes, ctx.control_period [s], ctx.dt [s],
        ctx.initial.quat, ctx.initial.omega, ctx.end_time [s]."""
        wn, zeta = params.natural_frequency_rad_s, params.damping_ratio
        self.kp, self.kd = wn * wn, 2.0 * zeta * wn        # [1/s^2], [1/s]
        self.inertia = np.asarray(ctx.inertia, dtype=float)
        self.target = np.asarray(params.target_quat, dtype=float)

    def torque(self, t, estimate):
        """Called every control period.
        t: time [s]; estimate: the estimator's output, here
            estimate["quat"]  (4,) attitude (w, x, y, z), body to world
            estimate["omega"] (3,) body angular rate [rad/s], body axes
        Returns a dict: "torque" (3,) the wanted body torque [N m, body axes], finite;
        every other key (a finite array of fixed shape) is recorded too, as law/<key>.
        An exception, a NaN or a wrong shape ends the run with status "error"."""
        q, w = estimate["quat"], estimate["omega"]
        error = attitude_error(self.target, q)                       # [rad], body axes
        torque = -self.inertia @ (self.kp * error + self.kd * w)     # PD on the error
        torque += np.cross(w, self.inertia @ w)                      # cancel w x I w
        return {"torque": torque, "attitude_error": error}


def attitude_error(target, q):
    """2 vec(target~ o q), the short way [rad]: about the rotation vector for small errors."""
    tw, tv, qw, qv = target[0], -target[1:], q[0], q[1:]            # target~ = (tw, -tv)
    ew = tw * qw - tv @ qv
    ev = tw * qv + qw * tv + np.cross(tv, qv)
    return 2.0 * (ev if ew >= 0 else -ev)


@testbed.metric("my_final_attitude_error_deg",
                applies=lambda scenario: scenario.stages["law"][0] == "my.controller",
                uses=("truth/quat",))  # the signals it reads: the run keeps only their history
def final_attitude_error_deg(run):
    """Angle between the final attitude and the law's target_quat [deg]."""
    target = np.asarray(run.scenario.stages["law"][1].target_quat, dtype=float)
    error = attitude_error(target, run.recorder["truth/quat"][-1])  # the true final attitude
    return float(np.degrees(2.0 * np.arcsin(min(1.0, np.linalg.norm(error) / 2.0))))
'''


@command("init")
def add_parser(subparsers) -> None:
    p = subparsers.add_parser("init", help="write a scenario and a controller template into a new folder")
    p.add_argument("dir", metavar="DIR", help="folder to create (it may exist if empty)")
    p.set_defaults(func=run)


def _target_folder(folder: Path) -> bool:
    """Create `folder`, or accept it if it is an empty folder; refuse anything else. Whether it was created."""
    try:
        if not folder.exists():
            check_creatable(folder.resolve() / CONTROLLER_FILE, str(folder))
    except (OSError, ValueError) as exc:
        raise InputError(quoted(str(folder)), f"is not a usable folder name: {getattr(exc, 'strerror', None) or exc}") from None
    if folder.exists() and not folder.is_dir():
        raise InputError(str(folder), "exists and is not a folder")
    if folder.is_dir() and any(folder.iterdir()):
        raise InputError(str(folder), "is not empty; testbed init writes only into a new or empty folder "
                                      "and never overwrites a file")
    created = not folder.exists()
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(str(folder), f"cannot create it: {exc.strerror or exc}") from None
    return created


def _write_new(path: Path, text: str) -> None:
    """`text` into the new file `path`, whole or not at all (testbed.recording.atomic_file): a
    full disk is WriteFailed naming it (exit 1); a file there already is refused, never replaced."""
    from testbed.recording.atomic_file import atomic_file

    try:
        with atomic_file(path, overwrite=False) as handle:
            handle.write(text)
    except FileExistsError:
        raise InputError(str(path), "already exists; testbed init never overwrites a file") from None


def run(args) -> int:
    if not str(args.dir).strip():  # Path("") is ".": an empty name would write into the current folder
        raise InputError("DIR", "is empty; name the folder to create (`.` for the current one, if empty)")
    folder = Path(args.dir)
    created = _target_folder(folder)
    scenario, controller = folder / SCENARIO_FILE, folder / CONTROLLER_FILE
    for path in (scenario, controller):  # refuse before writing anything
        if path.exists():
            raise InputError(str(path), "already exists; testbed init never overwrites a file")
    written: list[Path] = []
    try:
        for path, text in ((controller, CONTROLLER_TEMPLATE),
                           (scenario, SCENARIO_TEMPLATE.format(scenario_path=scenario.as_posix()))):
            _write_new(path, text)
            written.append(path)
    except BaseException:  # a template alone is half a project: nothing of this init is left
        for path in written:
            path.unlink(missing_ok=True)
        if created:
            with contextlib.suppress(OSError):  # the folder itself, and only if empty
                folder.rmdir()
        raise
    run_it = f"testbed run {scenario.as_posix()}"
    def report():
        print(f"wrote {scenario} (the experiment) and {controller} (your law \"my.controller\")")
        print("next:")
        print(f"  {run_it:44s} # runs as it is: exit 0, every check passes")
        print(f"  {'edit ' + controller.as_posix():44s} # torque(t, estimate) -> wanted body torque [N m]")
        print(f"  {run_it:44s} # again; the trace is runs/my_scenario.rrd (viewer: rerun runs/my_scenario.rrd)")
    return reported(EXIT_OK, report)
