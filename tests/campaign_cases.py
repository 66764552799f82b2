"""What the campaign tests share: a short spin-up to disperse, a bit-for-bit row comparison, and a
plug-in law that logs the runs of each case (and can kill its process) so a test can count them."""

from __future__ import annotations

import contextlib
import copy
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from testbed.scenario.yaml_reading import read_yaml
from testbed.scenario.shipped_files import SCENARIO_DIR


def spinup(name: str, checks: dict, noise_rad_s: float | None = 1e-7) -> dict:
    """scenarios/lebedev_spinup_ideal.yaml (one rate gyro, a rigid bus with ideal torques) cut to
    20 s, the observer still alone: a fraction of a second a case."""
    data = copy.deepcopy(read_yaml(SCENARIO_DIR / "lebedev_spinup_ideal.yaml"))
    data.update(name=name, checks=checks)
    data["sim"]["duration_s"] = 20
    if noise_rad_s is not None:
        data["pipeline"]["sensor"]["noise_sigma_rad_s"] = noise_rad_s
    return data


def same_cells(a: dict, b: dict) -> bool:
    """The same cells with the same values bit for bit (NaN equals NaN), wall time aside."""
    keys = set(a) - {"wall_s"}
    return keys == set(b) - {"wall_s"} and all(
        a[k] == b[k] or (isinstance(a[k], float) and math.isnan(a[k]) and math.isnan(b[k])) for k in keys)


LOGGED_LAW = '''"""A zero-torque law that logs its case's tag and process at its first tick; with tag == die_at
it then kills its process (SIGKILL: a crash; os._exit from a stage only fails its run)."""
import os
import signal
from dataclasses import dataclass

import numpy as np

from testbed.pipeline import stage
from testbed.scenario.schema import param


@dataclass(kw_only=True)
class LoggedParams:
    tag: int = param(0)
    die_at: int = param(-1)
    log: str = param("")


@stage("law", "test.logged", LoggedParams)
class Logged:
    def __init__(self, params, ctx):
        self.params = params
        self.started = False

    def torque(self, t, estimate):
        if not self.started:
            self.started = True
            with open(self.params.log, "a") as handle:
                handle.write(f"{self.params.tag} {os.getpid()}\\n")
            if self.params.tag == self.params.die_at:
                os.kill(os.getpid(), signal.SIGKILL)
        return {"torque": np.zeros(3)}
'''


@contextlib.contextmanager
def hand_started_cluster(cwd: Path, worker_names=("w1",), **env):
    """`dask scheduler` on a free loopback port and one single-threaded `dask worker` process per
    name, started in `cwd` with this process's import path (and `env` added); yields the
    scheduler's address once every worker has joined; stopped (SIGTERM, then kill) at the end."""
    from distributed import Client

    dask = Path(sys.executable).with_name("dask")  # the CLI of the dask package, beside this Python
    scheduler_file = Path(cwd) / "scheduler.json"
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL, "cwd": cwd,
             "env": dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path), **env)}
    processes = [subprocess.Popen([str(dask), "scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                                   "--scheduler-file", str(scheduler_file)], **quiet)]
    try:
        deadline = time.monotonic() + 120
        while not scheduler_file.exists() or not scheduler_file.read_text().strip():
            assert time.monotonic() < deadline and processes[0].poll() is None, "the scheduler did not start"
            time.sleep(0.1)
        for name in worker_names:
            processes.append(subprocess.Popen([str(dask), "worker", "--scheduler-file", str(scheduler_file),
                                               "--nthreads", "1", "--nworkers", "1", "--no-dashboard",
                                               "--name", name], **quiet))
        address = json.loads(scheduler_file.read_text())["address"]
        with Client(address, timeout=60) as client:  # every worker is there before the first case
            client.wait_for_workers(len(worker_names), timeout=120)
        yield address
    finally:
        for process in reversed(processes):
            process.send_signal(signal.SIGTERM)
        for process in processes:
            try:
                process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
