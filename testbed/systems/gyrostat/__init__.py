"""Gyrostat (models/gyrostat.xml): a bus carrying one free-spinning rotor.

With no torque on the rotor hinge the rotor's absolute axial spin is conserved, so its
momentum in the bus frame, h = Js (Omega_rel + w.a) a, is constant: the body obeys the
gyrostat equation I' w' + w x (I' w + h) = 0 with I' = I_locked - Js a a^T (the locked
inertia less the rotor's axial part, which h already carries). Reference `gyrostat`
integrates that equation (testbed.references.gyrostat_ode) for comparison with the truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from testbed.errors import InputError
from testbed.systems.free_bus import FreeBus
from testbed.math.validation import check_principal_inertia, check_unit_vector
from testbed.scenario.shipped_files import compile_model, load_spec
from testbed.plant import Plant
from testbed.references.registry import reference
from testbed.scenario.schema import join, param
from testbed.systems.registry import system


@dataclass
class GyrostatParams:
    system: str = "gyrostat"
    inertia_kg_m2: list[float] = param([800.0, 1000.0, 1200.0], length=3, doc="bus principal inertia")
    mass_kg: float = param(1000.0, gt=0)
    rotor_axis: list[float] = param([1.0, 0.0, 0.0], length=3, doc="unit spin axis, body axes")
    rotor_spin_inertia_kg_m2: float = param(0.08, gt=0)
    rotor_transverse_inertia_kg_m2: float = param(0.04, gt=0)
    rotor_speed_rpm: float = param(6000.0, doc="initial speed relative to the bus")

    def validate(self, path: str) -> None:
        check_principal_inertia(self.inertia_kg_m2, join(path, "inertia_kg_m2"))
        self.rotor_axis = list(check_unit_vector(self.rotor_axis, join(path, "rotor_axis")))
        js, jt = self.rotor_spin_inertia_kg_m2, self.rotor_transverse_inertia_kg_m2
        if js > 2 * jt + 1e-12:
            raise InputError(join(path, "rotor_spin_inertia_kg_m2"),
                             f"an axisymmetric rotor needs Js <= 2 Jt, got {js:g} > {2 * jt:g}")


def build(params: GyrostatParams, dt: float, integrator: str) -> mujoco.MjModel:
    """Compile models/gyrostat.xml with `params` applied through MjSpec."""
    spec = load_spec("gyrostat.xml", dt, integrator)
    spec.option.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    bus = spec.body("bus")
    bus.mass = params.mass_kg
    bus.inertia = params.inertia_kg_m2
    rotor_joint = spec.joint("rotor")
    rotor_joint.axis = params.rotor_axis
    rotor = spec.body("rotor")
    # The rotor's inertial frame: diaginertia is (Js, Jt, Jt) along the hinge axis.
    rotor.inertia = [params.rotor_spin_inertia_kg_m2, params.rotor_transverse_inertia_kg_m2,
                     params.rotor_transverse_inertia_kg_m2]
    rotor.iquat = _quat_x_to(np.asarray(params.rotor_axis, float))
    spec.geom("rotor").fromto = np.concatenate([-0.03 * np.asarray(params.rotor_axis), 0.03 * np.asarray(params.rotor_axis)])
    return compile_model(spec)


def _quat_x_to(axis: np.ndarray) -> np.ndarray:
    """Unit quaternion rotating the x axis onto `axis` (shortest arc)."""
    x = np.array([1.0, 0.0, 0.0])
    c = float(x @ axis)
    if c < -1 + 1e-12:
        return np.array([0.0, 0.0, 1.0, 0.0])
    q = np.concatenate([[1.0 + c], np.cross(x, axis)])
    return q / np.linalg.norm(q)


class GyrostatPlant(Plant):
    """Knows the rotor hinge by name; the rotor has no actuator."""

    holds_internal_momentum = True

    def __init__(self, model: mujoco.MjModel, params: GyrostatParams):
        super().__init__(FreeBus(model))
        self._rotor_dof = model.joint("rotor").dofadr[0]
        self.axis = np.asarray(params.rotor_axis, float)
        self.spin_inertia = params.rotor_spin_inertia_kg_m2
        self.params = params

    def initialise(self, initial) -> None:
        self.data.qvel[self._rotor_dof] = self.params.rotor_speed_rpm * 2 * np.pi / 60
        super().initialise(initial)

    def rotor_momentum_body(self) -> np.ndarray:
        """h = Js (Omega_rel + w.a) a: the rotor's axial momentum, constant in the bus frame."""
        spin = self.data.qvel[self._rotor_dof] + self.omega() @ self.axis
        return self.spin_inertia * spin * self.axis

    def gyrostat_inertia(self) -> np.ndarray:
        """I' = I_locked - Js a a^T: the inertia that multiplies w in L = I' w + h."""
        return self.locked_inertia() - self.spin_inertia * np.outer(self.axis, self.axis)

    def truth(self) -> dict[str, np.ndarray]:
        signals = super().truth()
        signals["rotor_rate"] = np.array([self.data.qvel[self._rotor_dof]])
        return signals

    def internal_momentum_body(self) -> np.ndarray:
        return self.rotor_momentum_body()


@system("gyrostat", GyrostatParams)
def make_plant(params: GyrostatParams, sim) -> GyrostatPlant:
    return GyrostatPlant(build(params, sim.dt_s, sim.integrator), params)


@reference("gyrostat", systems=("gyrostat",))
def _gyrostat(plant, params):
    """Gyrostat with constant rotor momentum, I' w' + w x (I' w + h) = 0 (solve_ivp)."""
    from testbed.references.gyrostat_ode import gyrostat_omega

    inertia, h, omega0 = plant.gyrostat_inertia(), plant.rotor_momentum_body(), plant.omega()
    return lambda times, recorder: gyrostat_omega(inertia, h, omega0, times - times[0])
