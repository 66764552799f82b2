"""Run metrics by name, computed from the recorded signals after a run; checks bound them.

A metric registers with `@metric(name, applies)`, where `applies(scenario)` says whether
the metric exists for that scenario; a check naming a metric that does not exist is bad
input, caught before the run.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from testbed.errors import InputError


@dataclass(frozen=True)
class Metric:
    name: str
    doc: str
    applies: Callable
    compute: Callable


METRICS: dict[str, Metric] = {}


def metric(name: str, applies: Callable = lambda scenario: True):
    """Register `fn(run) -> float` as metric `name` (docstring = its definition)."""

    def register(fn):
        METRICS[name] = Metric(name, (fn.__doc__ or "").strip().splitlines()[0], applies, fn)
        return fn

    return register


def available(scenario) -> list[str]:
    return [name for name, m in METRICS.items() if m.applies(scenario)]


def validate_checks(scenario) -> None:
    names = available(scenario)
    for name in scenario.checks:
        if name not in names:
            raise InputError(f"checks.{name}", f"no such metric for this scenario (available: {', '.join(names)})")


def compute_all(run) -> dict[str, float]:
    return {name: float(METRICS[name].compute(run)) for name in available(run.scenario)}


def evaluate_checks(scenario, values: dict[str, float]) -> list[dict]:
    return [{"name": name, "value": values[name], "limit": limit.text, "passed": limit.passed(values[name])}
            for name, limit in scenario.checks.items()]


# --- metrics every free-flying system has ---------------------------------------------------

def _free_flying(scenario) -> bool:
    from testbed import systems

    return systems.is_free_flying(scenario)


def _conserves_momentum(scenario) -> bool:
    """A free body whose actuators are all internal (no ideal external torque)."""
    from testbed import pipeline

    return _free_flying(scenario) and pipeline.output_of("allocator", scenario.stages["allocator"][0]) != "body_torque"


@metric("momentum_drift_rel", applies=_conserves_momentum)
def momentum_drift_rel(run) -> float:
    """max |L(t) - L(0)| / L_scale of the total inertial angular momentum; L_scale = max(|L(0)|, stored rotor momentum)."""
    L = run.recorder["truth/angular_momentum_world"]
    return float(np.max(np.linalg.norm(L - L[0], axis=1)) / run.momentum_scale)


@metric("energy_drift_rel", applies=lambda s: s.stages["allocator"][0] == "none")
def energy_drift_rel(run) -> float:
    """max |T(t) - T(0)| / T(0) of the kinetic energy (no actuator does work)."""
    T = run.recorder["truth/kinetic_energy"][:, 0]
    return float(np.max(np.abs(T - T[0])) / max(abs(T[0]), 1e-300))


@metric("max_omega_error_rad_s", applies=lambda s: s.reference is not None)
def max_omega_error_rad_s(run) -> float:
    """max over samples of |w_truth - w_reference| (body frame) [rad/s]."""
    return float(np.max(np.linalg.norm(run.recorder["reference/omega_error"], axis=1)))


@metric("final_omega_rad_s", applies=lambda s: _free_flying(s))
def final_omega_rad_s(run) -> float:
    """|w| of the bus at the end of the run [rad/s]."""
    return float(np.linalg.norm(run.recorder["truth/omega"][-1]))


# --- CMG cluster ---------------------------------------------------------------------------

def _is_cmg(scenario) -> bool:
    return scenario.system == "cmg_rhombus"


@metric("gimbal_rate_error_rel", applies=lambda s: _is_cmg(s) and s.stages["allocator"][0] != "none")
def gimbal_rate_error_rel(run) -> float:
    """max_i max_t |b'_i(t_k+1) - cmd_i(t_k)| / max_t |cmd_i|: servo tracking of the held command, after 0.1 s."""
    rates = run.recorder["truth/gimbal_rate"][1:]
    command = run.recorder["allocator/gimbal_rates"][:-1]  # held over (t_k, t_k+1]
    keep = run.recorder.time[1:] > 0.1
    scale = np.maximum(np.nanmax(np.abs(command), axis=0), 1e-12)
    return float(np.nanmax(np.abs(rates[keep] - command[keep]) / scale))

from testbed import metrics_steering  # noqa: E402,F401
from testbed import metrics_lebedev  # noqa: E402,F401

# issue 5: planar AKOR figures measured in simulation
from testbed import metrics_planar  # noqa: E402,F401
from testbed import metrics_gyrostat  # noqa: E402,F401
