"""Analytic reference models a scenario's truth is compared with (`reference: {type: NAME}`).

A reference is prepared from the plant at t = 0 (design data and initial state, never the
later truth) and evaluated at the trace sample times after the run. The reduced CMG model
also takes the recorded gimbal and rotor histories: they are its input, as in the paper.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from testbed import schema
from testbed.errors import InputError


@dataclass
class _NoParams:
    pass


@dataclass(frozen=True)
class ReferenceKind:
    systems: tuple[str, ...]
    params: type
    prepare: Callable   # (plant, params) -> evaluate(times, recorder) -> omega (N, 3)


REFERENCES: dict[str, ReferenceKind] = {}


def reference(name: str, systems: tuple[str, ...], params: type = _NoParams):
    def register(prepare):
        REFERENCES[name] = ReferenceKind(systems, params, prepare)
        return prepare

    return register


def load_params(config: dict, path: str):
    config = dict(config)
    name = config.pop("type", None)
    if name not in REFERENCES:
        raise InputError(f"{path}.type", f"unknown reference {name!r} (one of {', '.join(sorted(REFERENCES))})")
    return name, schema.load(REFERENCES[name].params, config, path)


def check_system(scenario) -> None:
    if scenario.reference is None:
        return
    name, _ = scenario.reference
    allowed = REFERENCES[name].systems
    if scenario.system not in allowed:
        raise InputError("reference.type", f"{name} needs model.system in {list(allowed)}, got {scenario.system!r}")


def prepare(scenario, plant):
    name, params = scenario.reference
    return REFERENCES[name].prepare(plant, params)


@reference("torque_free", systems=("satellite",))
def _torque_free(plant, params):
    """Closed-form torque-free rigid body (Jacobi elliptic functions)."""
    from testbed.references.torque_free import torque_free_omega

    inertia = plant.locked_inertia()
    if np.max(np.abs(inertia - np.diag(np.diag(inertia)))) > 1e-9 * np.max(np.abs(inertia)):
        raise InputError("reference.type", "torque_free needs principal body axes")
    principal, omega0 = np.diag(inertia).copy(), plant.omega()
    return lambda times, recorder: torque_free_omega(principal, omega0, times - times[0])


@reference("gyrostat", systems=("gyrostat",))
def _gyrostat(plant, params):
    """Gyrostat with constant rotor momentum, I' w' + w x (I' w + h) = 0 (solve_ivp)."""
    from testbed.references.gyrostat_ode import gyrostat_omega

    inertia, h, omega0 = plant.gyrostat_inertia(), plant.rotor_momentum_body(), plant.omega()
    return lambda times, recorder: gyrostat_omega(inertia, h, omega0, times - times[0])


@dataclass(kw_only=True)
class ReducedCmgParams:
    # 1e-9 puts the integrator's own error near 1e-9 rad/s, far inside the usual 1e-6 bound;
    # tighter tolerances cost 20x more because each control tick's servo transient is resolved.
    rtol: float = schema.param(1e-9, gt=0, lt=1e-3)


@reference("reduced_cmg", systems=("cmg_rhombus",), params=ReducedCmgParams)
def _reduced_cmg(plant, params):
    """Reduced CMG model L_b' = -w x L_b, w = I_sys(b)^-1 (L_b - H_int) from the recorded
    gimbal and rotor histories (testbed.references.reduced_cmg)."""
    from testbed.references.reduced_cmg import CmgMassModel, reduced_cmg_omega

    mass_model, omega0 = CmgMassModel.from_model(plant.model), plant.omega()

    def evaluate(times, recorder):
        return reduced_cmg_omega(mass_model, times, recorder["truth/gimbal_angle"], recorder["truth/gimbal_rate"],
                                 recorder["truth/rotor_rate"], omega0, times, rtol=params.rtol, atol=1e-14)

    return evaluate


@reference("gyrostat_leader", systems=("gyrostat_pair",))
def _gyrostat_leader(plant, params):
    """The leader of seed 003, eq. (1) with constant lambda: A w' + w x (A w + lambda) = 0
    (solve_ivp); A = its locked inertia from mj_fullM, lambda = J x rotor speeds at t = 0."""
    from testbed.references.gyrostat_ode import gyrostat_omega

    inertia, moment, omega0 = plant.locked_inertia(), plant.domain.moment("leader"), plant.omega()
    return lambda times, recorder: gyrostat_omega(inertia, moment, omega0, times - times[0])
