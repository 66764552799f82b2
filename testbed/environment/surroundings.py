"""The bus in orbit: at every update (environment.update_period_s, a whole number of control
periods) the orbit's state at the plant's time, the Sun and the shadow, the field, each
torque the scenario switches on, and the magnetorquers' dipole from the desaturation law;
their sum is written into MuJoCo's `xfrc_applied` of the bus (world axes), held until the
next update at its value extrapolated to the period's midpoint (midpoint_hold.py). What
depends on the orbit alone is read from blocks of update instants (along_orbit.py): the
attitude never changes it. Every value is recorded with the truth (`truth/orbit_position`, ...,
docs/theory/environment.md "Trace")."""

from __future__ import annotations

import dataclasses

import numpy as np

from testbed.environment.along_orbit import AlongOrbit
from testbed.environment.atmosphere import VALID_ALTITUDE_KM, MsisDensity
from testbed.environment.desaturation import desaturation_dipole
from testbed.environment.facets import Facets
from testbed.environment.gravity_gradient import gravity_gradient_torque
from testbed.environment.magnetic_field import IGRF_SPAN_YEARS
from testbed.environment.midpoint_hold import MidpointHold
from testbed.errors import InputError
from testbed.math.cross import cross3
from testbed.math.quaternion import quat_conj, quat_mul, quat_to_matrix
from testbed.orbit.config import initial_in_eci
from testbed.orbit.constants import AU_M, EARTH_RADIUS_M, EARTH_RATE_RAD_S, SOLAR_PRESSURE_1AU_N_M2
from testbed.orbit.frames import lvlh_quat
from testbed.orbit.sun import in_cylindrical_shadow
from testbed.plant import SimulationDiverged
from testbed.scenario.schema import whole_multiple

ZERO3 = np.zeros(3)


def in_orbit(scenario):
    """The scenario with its initial attitude and rate in ECI (testbed.orbit.config.initial_in_eci)."""
    if scenario.orbit is None:
        return scenario
    return dataclasses.replace(scenario, initial=initial_in_eci(scenario.orbit, scenario.initial))


class Surroundings:
    """The orbit and the environment of one plant (see the module doc)."""

    def __init__(self, orbit_params, params, plant, sim):
        self.params = params
        self.bus_id = plant.bus.bus_body_id
        self.wrench = plant.data.xfrc_applied[self.bus_id]
        if params is None:
            self.period = sim.control_period_s
        else:
            whole_multiple(params.update_period_s, sim.control_period_s, "environment.update_period_s",
                           "sim.control_period_s")
            self.period = params.update_period_s
        self.next_time = 0.0
        # it is called every control tick, on MuJoCo's clock, a sum of steps that drifts from
        # the whole multiples (1e-9 s short after 23 100 steps of 0.1 s): an update is due from half a tick early
        self.early = 0.5 * sim.control_period_s
        self.signals: dict[str, np.ndarray] = {}
        self.epoch = orbit_params.epoch()
        self._check_fit(orbit_params, plant, sim)
        p = params
        if p is not None and (p.drag is not None or p.solar_pressure is not None):
            half = p.facet_half_size_m or plant.scene()["bus_half_size"]
            self.facets = Facets(half, p.centre_of_pressure_offset_m)
        density = None
        if p is not None and p.drag is not None:
            density = (MsisDensity(p.drag.f107_sfu, p.drag.ap) if p.drag.atmosphere == "nrlmsis"
                       else "exponential")
        self.along = AlongOrbit(orbit_params.propagator(), self.epoch, self.period,
                                int(sim.duration_s / self.period + 1e-9),
                                sun=p is not None and p.sun, moon=p is not None and p.moon,
                                density_model=density,
                                field_model=None if p is None or p.magnetic_field is None else p.magnetic_field.model)
        self.noise = None
        if p is not None and p.magnetometer is not None and p.magnetometer.noise_t > 0:
            self.noise = np.random.default_rng(p.magnetometer.seed)
        self.dipole = ZERO3
        self.applied_world = np.zeros(6)  # the wrench held on the bus until the next update
        # the environment's torque (world axes) and the field the magnetorquers' held dipole
        # turns in (body axes), each held at its extrapolated midpoint value (midpoint_hold.py)
        self.torque_hold, self.field_hold = MidpointHold(self.period), MidpointHold(self.period)
        self.shadow = None

    def _check_fit(self, orbit_params, plant, sim) -> None:
        """Refuse, before the run, magnetorquers with no momentum to unload, an orbit the drag
        model is not valid at, or a run outside the field model's years."""
        if self.params is None:
            return
        torquers = self.params.magnetorquers
        if torquers is not None and torquers.desaturation and not plant.holds_internal_momentum:
            raise InputError("environment.magnetorquers", "the desaturation law unloads a momentum device "
                             "(rotors, CMGs), and this model holds none: its dipole would stay zero "
                             "(desaturation: false flies idle magnetorquers)")
        if self.params.magnetic_field is not None:
            first, last = (self.epoch.utc_datetime64(t).astype("datetime64[Y]").astype(int) + 1970
                           for t in (0.0, sim.duration_s))
            low, high = IGRF_SPAN_YEARS
            if first < low or last >= high:
                raise InputError("orbit.epoch_utc", f"the run ({first}-{last}) is outside IGRF-14's years "
                                 f"{low}-{high - 1}, which environment.magnetic_field needs")
        if self.params.drag is None:
            return
        perigee, apogee = orbit_params.perigee_apogee_m()
        low, high = VALID_ALTITUDE_KM
        for name, radius in (("perigee", perigee), ("apogee", apogee)):
            altitude_km = (radius - EARTH_RADIUS_M) / 1e3
            if not low <= altitude_km <= high:
                raise InputError("environment.drag.atmosphere", f"the {name} altitude {altitude_km:.4g} km is "
                                 f"outside the atmosphere model's validity [{low:g}, {high:g}] km")

    def update(self, plant) -> None:
        """Recompute and apply the torques if an update is due at the plant's time."""
        t = plant.data.time
        if t < self.next_time - self.early:
            return
        self.next_time = (round(t / self.period) + 1) * self.period
        try:
            self._update(t, plant)
        except ValueError as exc:  # SGP4 gave up on the orbit (it decayed): the run ends there
            raise SimulationDiverged(t, f"the orbit cannot be propagated: {exc}") from None

    def _update(self, t: float, plant) -> None:
        p = self.params
        here = self.along.at(t)
        r, v = here["r"], here["v"]
        q = plant.quat()
        to_world = quat_to_matrix(q)
        r_body = to_world.T @ r
        relative = quat_mul(quat_conj(lvlh_quat(r, v)), q)
        signals = {"orbit_position": r, "orbit_velocity": v,
                   "quat_lvlh": relative if relative[0] >= 0 else -relative}  # one sign: a continuous trace
        total = np.zeros(3)
        magnetorquer_world = ZERO3
        shadow = None
        if p is not None:
            if p.gravity_gradient:
                torque = gravity_gradient_torque(r_body, plant.bus.system_inertia(plant.data))
                signals["torque_gravity_gradient"] = torque
                total = total + torque
            if p.sun:
                sun = here["sun"]
                shadow = p.eclipse and in_cylindrical_shadow(r, sun)
                signals["eclipse"] = np.array([1.0 if shadow else 0.0])
                to_sun = sun - r
                distance = float(np.linalg.norm(to_sun))
                signals["sun_direction"] = to_world.T @ (to_sun / distance)
                if p.solar_pressure is not None:
                    pressure = 0.0 if shadow else SOLAR_PRESSURE_1AU_N_M2 * (AU_M / distance) ** 2
                    torque = self.facets.solar_pressure_torque(signals["sun_direction"], pressure,
                                                              p.solar_pressure.specular, p.solar_pressure.diffuse)
                    signals["torque_solar_pressure"] = torque
                    total = total + torque
            if p.moon:
                to_moon = here["moon"] - r   # seen from the spacecraft: the parallax, up to 1.1 deg, is in
                signals["moon_direction"] = to_world.T @ (to_moon / np.linalg.norm(to_moon))
            if p.drag is not None:
                # the air turns with the Earth: v_rel = v - omega_E pole x r
                v_rel = v - EARTH_RATE_RAD_S * cross3(here["pole"], r)
                torque = self.facets.drag_torque(to_world.T @ v_rel, here["density"], p.drag.drag_coefficient)
                signals["torque_drag"] = torque
                total = total + torque
            if p.magnetic_field is not None:
                field = to_world.T @ here["field"]
                signals["magnetic_field"] = field
                torque = cross3(np.asarray(p.magnetic_field.residual_dipole_am2, float), field)
                signals["torque_residual_dipole"] = torque
                total = total + torque
                if p.magnetorquers is not None:
                    dipole = self._desaturation(field, plant, signals)
                    magnetorquer_world = to_world @ cross3(dipole, self.field_hold(t, field))
        # a step of the solar pressure into or out of the shadow is held as it is, not extrapolated
        smooth = shadow == self.shadow
        self.shadow = shadow
        applied = self.torque_hold(t, to_world @ total, smooth) + magnetorquer_world
        self.applied_world = np.concatenate([ZERO3, applied])  # (force, torque), world axes
        self.wrench[:] = self.applied_world
        signals["torque_environment"] = to_world.T @ applied  # what is held over the coming period
        self.signals = signals

    def _desaturation(self, field, plant, signals) -> np.ndarray:
        """The magnetorquers' dipole (body axes) [A m^2], held until the next update: the
        desaturation law's on the magnetometer's reading of the field (body axes) [T]; the
        torque it makes at the field's instant value is recorded."""
        p = self.params
        measured = field if self.noise is None else field + self.noise.normal(0.0, p.magnetometer.noise_t, 3)
        signals["magnetometer"] = measured
        m = p.magnetorquers
        if m.desaturation:
            self.dipole = desaturation_dipole(plant.internal_momentum_body(), np.asarray(m.target_momentum_nms),
                                              measured, m.gain_1_s, m.max_dipole_am2)
        signals["magnetorquer_dipole"] = self.dipole
        signals["torque_magnetorquer"] = cross3(self.dipole, field)
        return self.dipole


def prepare(scenario, plant):
    """The plant's `Surroundings` (None without an orbit), updated once at t = 0."""
    if scenario.orbit is None:
        return None
    surroundings = Surroundings(scenario.orbit, scenario.environment, plant, scenario.sim)
    surroundings.update(plant)
    return surroundings
