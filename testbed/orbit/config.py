"""The scenario's `orbit:` block: where the system flies, from classical elements or a TLE,
and the frame its `initial:` attitude and rate are given in."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from datetime import datetime, timezone
from typing import Literal

import numpy as np

from testbed.errors import InputError, quoted
from testbed.math.quaternion import quat_conj, quat_mul, quat_rotate
from testbed.orbit.constants import EARTH_RADIUS_M, MU_EARTH_M3_S2
from testbed.orbit.elements import state_from_elements
from testbed.orbit.frames import lvlh_quat, lvlh_rate
from testbed.orbit.propagation import GravityIntegrator, Orbit, Sgp4Source
from testbed.orbit.sun_synchronous import node_right_ascension, osculating_inclination, parse_local_time
from testbed.orbit.time_scales import Epoch, utc_parts
from testbed.scenario.schema import join, param

ORBIT_PATH = "orbit"
# What a run in orbit records (testbed.environment.surroundings), as `testbed describe block` lists it.
ORBIT_SIGNALS = ("truth/orbit_position (ECI, m)", "truth/orbit_velocity (ECI, m/s)",
                 "truth/quat_lvlh (body to LVLH, w >= 0)", "truth/torque_environment (sum, body axes, N m)")


@dataclass(kw_only=True)
class SunSynchronousParams:
    """A sun-synchronous orbit: its inclination and node from the local time of the node."""

    local_time_ascending_node: str = param(doc='local solar time of the ascending node at the epoch, '
                                           '"HH:MM" or "HH:MM:SS" (quoted: YAML reads 10:30 as a number)')
    solar_time: Literal["mean", "apparent"] = param("mean", doc="the local time's Sun: mean (fixed as the "
                                                    "node tracks the mean Sun) or apparent (the true Sun)")

    def validate(self, path: str) -> None:
        try:
            self.hours = parse_local_time(self.local_time_ascending_node)
        except ValueError as exc:
            raise InputError(join(path, "local_time_ascending_node"), str(exc)) from None


@dataclass(kw_only=True)
class OrbitParams:
    """The orbit: classical elements (propagated two-body + J2) or a TLE (propagated by SGP4)."""

    altitude_km: float | None = param(None, gt=0, le=1e6, doc="circular-orbit altitude above the equatorial "
                                      "radius; sets semi_major_axis_km (give one of the two)")
    semi_major_axis_km: float | None = param(None, gt=0, le=1e7, doc="semi-major axis a")
    eccentricity: float = param(0.0, ge=0, lt=1, doc="eccentricity e")
    inclination_deg: float = param(51.6, ge=0, le=180, doc="inclination i")
    raan_deg: float = param(0.0, ge=-360, le=360, doc="right ascension of the ascending node")
    arg_perigee_deg: float = param(0.0, ge=-360, le=360, doc="argument of perigee")
    true_anomaly_deg: float = param(0.0, ge=-360, le=360, doc="true anomaly at t = 0")
    tle: list[str] | None = param(None, length=2, doc="two-line element set (lines 1 and 2); replaces the elements")
    epoch_utc: str = param("2026-03-20T12:00:00", doc="UTC date and time of t = 0 (ISO 8601; a TLE's own epoch "
                           "when a TLE is given and this is left out)")
    j2: bool = param(True, doc="include the Earth's J2 in the propagation of elements")
    step_s: float = param(10.0, ge=0.1, le=600, doc="orbit integration step; states between are interpolated")
    sun_synchronous: SunSynchronousParams | None = param(None, doc="set inclination_deg and raan_deg for a "
                                                         "sun-synchronous orbit (J2) at a local time of the node")
    attitude_frame: Literal["eci", "lvlh"] = param("eci", doc="frame of initial.quat and initial.omega_*: "
                                                    "eci (inertial), or lvlh (relative to the orbit frame)")

    def validate(self, path: str) -> None:
        if self.tle is not None:
            if self.altitude_km is not None or self.semi_major_axis_km is not None:
                raise InputError(join(path, "tle"), "give a TLE or the elements, not both")
            if self.sun_synchronous is not None:
                raise InputError(join(path, "sun_synchronous"), "a TLE gives its own inclination and node")
            self.satrec = parse_tle(self.tle, join(path, "tle"))
            epoch_parts(self.epoch_utc, join(path, "epoch_utc"))
            self.check_propagates(path, (0.0, self.step_s))  # the grid's first states, read at t = 0
            return
        if (self.altitude_km is None) == (self.semi_major_axis_km is None):
            raise InputError(join(path, "semi_major_axis_km"), "give one of semi_major_axis_km and altitude_km")
        if self.altitude_km is not None:
            self.semi_major_axis_km = EARTH_RADIUS_M / 1e3 + self.altitude_km
        perigee_km = self.semi_major_axis_km * (1.0 - self.eccentricity)
        if perigee_km * 1e3 <= EARTH_RADIUS_M:
            raise InputError(join(path, "semi_major_axis_km"), f"the perigee radius {perigee_km:.6g} km is inside "
                             f"the Earth (radius {EARTH_RADIUS_M / 1e3:g} km)")
        epoch_parts(self.epoch_utc, join(path, "epoch_utc"))
        if self.sun_synchronous is not None:
            self._set_sun_synchronous(path)

    def _set_sun_synchronous(self, path: str) -> None:
        """inclination_deg and raan_deg of the sun-synchronous orbit (testbed.orbit.sun_synchronous)."""
        if not self.j2:
            raise InputError(join(path, "j2"), "a sun-synchronous orbit's node is turned by J2: set j2: true")
        fields = OrbitParams.__dataclass_fields__
        for name in ("inclination_deg", "raan_deg"):
            if getattr(self, name) != fields[name].default:
                raise InputError(join(path, name), "is set by sun_synchronous: leave it out")
        sso = self.sun_synchronous
        nu = math.radians(self.true_anomaly_deg)
        try:
            inclination = osculating_inclination(self.semi_major_axis_km * 1e3, self.eccentricity, nu,
                                                 nu + math.radians(self.arg_perigee_deg))
        except ValueError as exc:
            raise InputError(join(path, "altitude_km" if self.altitude_km is not None else "semi_major_axis_km"),
                             str(exc)) from None
        self.inclination_deg = math.degrees(inclination)
        self.raan_deg = math.degrees(node_right_ascension(self.epoch(), sso.hours, sso.solar_time))

    def check_propagates(self, path: str, times) -> None:
        """A TLE's SGP4 propagates to each of `times` [s] from t = 0, else bad input naming the field
        that puts the orbit there: epoch_utc when given, else the TLE (decayed, diverged)."""
        from sgp4.api import SGP4_ERRORS

        if self.tle is None:
            return
        own_epoch = self.epoch_utc == OrbitParams.__dataclass_fields__["epoch_utc"].default
        utc1, utc2 = self.epoch().utc
        for t in times:
            error, _, _ = self.satrec.sgp4(utc1, utc2 + t / 86400.0)
            if error:
                field = join(path, "tle" if own_epoch else "epoch_utc")
                raise InputError(field, f"SGP4 cannot propagate the TLE to t = {t:g} s "
                                 f"({SGP4_ERRORS.get(error, f'error {error}')})")

    def epoch(self) -> Epoch:
        """The UTC instant of t = 0 as a two-part Julian date (a TLE's own, kept as its two parts)."""
        if self.tle is not None and self.epoch_utc == OrbitParams.__dataclass_fields__["epoch_utc"].default:
            return Epoch(self.satrec.jdsatepoch, self.satrec.jdsatepochF)
        return Epoch(*epoch_parts(self.epoch_utc, join(ORBIT_PATH, "epoch_utc")))

    def perigee_apogee_m(self) -> tuple[float, float]:
        """Perigee and apogee radii [m] (of the TLE's mean elements when one is given)."""
        if self.tle is not None:
            a = (MU_EARTH_M3_S2 / (self.satrec.no_kozai / 60.0) ** 2) ** (1 / 3)
            return a * (1 - self.satrec.ecco), a * (1 + self.satrec.ecco)
        a = self.semi_major_axis_km * 1e3
        return a * (1 - self.eccentricity), a * (1 + self.eccentricity)

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        """(r, v) [m, m/s] at t = 0 of the elements (ECI)."""
        return state_from_elements(self.semi_major_axis_km * 1e3, self.eccentricity,
                                   *np.radians([self.inclination_deg, self.raan_deg, self.arg_perigee_deg,
                                                self.true_anomaly_deg]))

    def propagator(self) -> Orbit:
        """A fresh `Orbit` of this block: each reader owns one (they agree: the grid is the same)."""
        if self.tle is not None:
            return Orbit(Sgp4Source(self.satrec, self.epoch()), self.step_s)
        return Orbit(GravityIntegrator(*self.initial_state(), j2=self.j2), self.step_s)


def parse_tle(lines, path: str):
    """The sgp4 `Satrec` of two TLE lines; a set that does not parse is bad input naming `path`."""
    from sgp4.api import Satrec

    first, second = (str(line).rstrip() for line in lines)
    for i, line in enumerate((first, second)):
        if not line.isascii():
            raise InputError(f"{path}[{i}]", "holds a character that is not ASCII; a TLE line is plain ASCII")
    if not (first.startswith("1 ") and second.startswith("2 ") and len(first) >= 64 and len(second) >= 63):
        raise InputError(path, "is not a two-line element set (line 1 starts '1 ', line 2 '2 ', 69 columns each)")
    try:
        satrec = Satrec.twoline2rv(first, second)
    except (ValueError, IndexError) as exc:
        raise InputError(path, f"does not parse: {exc}") from None
    if satrec.error or not (satrec.no_kozai > 0 and 0 <= satrec.ecco < 1):
        raise InputError(path, f"does not parse: SGP4 refuses it (error {satrec.error})")
    error, _, _ = satrec.sgp4(satrec.jdsatepoch, satrec.jdsatepochF)
    if error:
        raise InputError(path, f"SGP4 cannot propagate it (error {error})")
    return satrec


def epoch_parts(text: str, path: str) -> tuple[float, float]:
    """Two-part UTC Julian date (day, fraction) of an ISO 8601 time (no zone: UTC)."""
    try:
        moment = datetime.fromisoformat(str(text))
    except ValueError:
        raise InputError(path, f"is not an ISO 8601 date and time: {quoted(text)}") from None
    if moment.tzinfo is not None:
        moment = moment.astimezone(timezone.utc)
    return utc_parts(moment.year, moment.month, moment.day, moment.hour, moment.minute,
                     moment.second + moment.microsecond * 1e-6)


def initial_in_eci(params: OrbitParams, initial):
    """The scenario's `initial` state with its attitude and rate in ECI: unchanged for
    attitude_frame eci; for lvlh, q = q_LVLH(0) ∘ q_rel and omega = omega_rel + R(q_rel)^T omega_LVLH."""
    if params.attitude_frame == "eci":
        return initial
    r, v = params.propagator().state(0.0)
    q_rel = np.asarray(initial.quat, float)
    rate, _ = lvlh_rate(r, v)
    omega = initial.omega + quat_rotate(quat_conj(q_rel), rate)
    return dataclasses.replace(initial, quat=list(quat_mul(lvlh_quat(r, v), q_rel)), omega_deg_s=None,
                               omega_rad_s=list(omega))


def circular_rate(a_m: float) -> float:
    """Mean motion n = sqrt(mu / a^3) [rad/s]."""
    return math.sqrt(MU_EARTH_M3_S2 / a_m**3)
