"""What the campaign tests share: a short spin-up to disperse, a bit-for-bit row comparison, and a
plug-in law that logs the runs of each case (and can kill its process) so a test can count them."""

from __future__ import annotations

import copy
import math

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
