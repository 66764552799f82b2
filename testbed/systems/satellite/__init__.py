"""Rigid satellite bus driven by ideal body-frame torques (models/satellite.xml).

Reference `torque_free`: the closed-form (Jacobi elliptic) body rates of the torque-free
rigid body, compared with the MuJoCo truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from testbed.errors import InputError
from testbed.systems.free_bus import FreeBus, set_bus_mass
from testbed.math.validation import check_principal_inertia
from testbed.scenario.shipped_files import compile_model, load_spec
from testbed.plant import Plant
from testbed.references.registry import reference
from testbed.scenario.schema import join, param
from testbed.systems.registry import system


@dataclass(kw_only=True)
class SatelliteParams:
    """A rigid bus driven by ideal body torques."""

    system: str = "satellite"
    inertia_kg_m2: list[float] = param([800.0, 1000.0, 1200.0], length=3, doc="principal inertia, body axes")
    mass_kg: float = param(1000.0, gt=0)

    def validate(self, path: str) -> None:
        check_principal_inertia(self.inertia_kg_m2, join(path, "inertia_kg_m2"))


def build(params: SatelliteParams, dt: float, integrator: str = "RK4") -> mujoco.MjModel:
    """Compile models/satellite.xml with the bus inertia and mass applied through MjSpec."""
    spec = load_spec("satellite.xml", dt, integrator)
    set_bus_mass(spec, params.inertia_kg_m2, params.mass_kg)
    return compile_model(spec)


@system("satellite", SatelliteParams)
def make_plant(params: SatelliteParams, sim) -> Plant:
    return Plant(FreeBus(build(params, sim.dt_s, sim.integrator)))


@reference("torque_free", systems=("satellite",))
def _torque_free(plant, params):
    """Closed-form torque-free rigid body (Jacobi elliptic functions)."""
    from testbed.references.torque_free import torque_free_omega

    inertia = plant.locked_inertia()
    if np.max(np.abs(inertia - np.diag(np.diag(inertia)))) > 1e-9 * np.max(np.abs(inertia)):
        raise InputError("reference.type", "torque_free needs principal body axes")
    principal, omega0 = np.diag(inertia).copy(), plant.omega()
    return lambda times, recorder: torque_free_omega(principal, omega0, times - times[0])
