"""The scenario's `environment:` block: which torques act on the bus in orbit, their models'
parameters, and the momentum-management loop (magnetometer, magnetorquers, desaturation)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from testbed.errors import InputError
from testbed.scenario.schema import join, param

# What each part records (testbed.environment.surroundings), as `testbed describe block` lists it.
ENVIRONMENT_SIGNALS = (
    "truth/torque_gravity_gradient, truth/torque_drag, truth/torque_solar_pressure, truth/torque_residual_dipole, "
    "truth/torque_magnetorquer (body axes, N m)", "truth/eclipse (1 in the shadow)",
    "truth/sun_direction (unit, body axes)", "truth/moon_direction (unit, body axes)",
    "truth/magnetic_field (body axes, T)",
    "truth/magnetometer (body axes, T)", "truth/magnetorquer_dipole (body axes, A m^2)",
    "truth/envelope_share (a CMG cluster's momentum over its envelope)")


@dataclass(kw_only=True)
class DragParams:
    """Aerodynamic drag on the bus's facets."""

    atmosphere: Literal["exponential", "nrlmsis"] = param("exponential", doc="density model: Vallado's "
                                                          "exponential table, or NRLMSIS 2.1 (pymsis)")
    drag_coefficient: float = param(2.2, gt=0, le=10, doc="Cd of every facet")
    f107_sfu: float = param(150.0, ge=60, le=300, doc="F10.7 solar flux held fixed (nrlmsis)")
    ap: float = param(15.0, ge=0, le=400, doc="geomagnetic Ap index held fixed (nrlmsis)")


@dataclass(kw_only=True)
class SolarPressureParams:
    """Solar radiation pressure on the bus's facets (none in the Earth's shadow)."""

    specular: float = param(0.1, ge=0, le=1, doc="specular reflectivity rho_s of every facet")
    diffuse: float = param(0.2, ge=0, le=1, doc="diffuse reflectivity rho_d of every facet")

    def validate(self, path: str) -> None:
        if self.specular + self.diffuse > 1.0:
            raise InputError(join(path, "diffuse"), f"specular + diffuse must be <= 1, got "
                                                    f"{self.specular + self.diffuse:g}")


@dataclass(kw_only=True)
class MagneticParams:
    """The geomagnetic field (IGRF-14) and the bus's residual dipole in it."""

    model: Literal["igrf", "dipole"] = param("igrf", doc="field model: IGRF-14 to degree 13, or its degree 1 "
                                             "alone (a tilted dipole); both with secular variation")
    residual_dipole_am2: list[float] = param([0.0, 0.0, 0.0], length=3, doc="the bus's residual dipole, body axes")


@dataclass(kw_only=True)
class MagnetometerParams:
    """A three-axis magnetometer: the true field plus seeded white noise."""

    noise_t: float = param(0.0, ge=0, le=1e-4, doc="standard deviation of the noise per axis")
    seed: int = param(0, ge=0, doc="noise seed")


@dataclass(kw_only=True)
class MagnetorquerParams:
    """Three orthogonal magnetorquers along the body axes, commanded by the cross-product
    desaturation law m = k (dH x B) / |B|^2 (testbed.environment.desaturation)."""

    max_dipole_am2: list[float] = param([100.0, 100.0, 100.0], length=3, doc="dipole limit of each axis")
    gain_1_s: float = param(1e-3, gt=0, le=1.0, doc="desaturation gain k (the momentum error's decay rate "
                            "across the field)")
    target_momentum_nms: list[float] = param([0.0, 0.0, 0.0], length=3, doc="cluster momentum to hold, body axes")
    desaturation: bool = param(True, doc="run the desaturation law (false: magnetorquers idle)")

    def validate(self, path: str) -> None:
        if min(self.max_dipole_am2) <= 0:
            raise InputError(join(path, "max_dipole_am2"), "every limit must be > 0")


@dataclass(kw_only=True)
class EnvironmentParams:
    """The torques of the orbit on the bus and the momentum-management loop, updated every
    update_period_s and held between updates at their midpoint extrapolation (applied through
    MuJoCo's xfrc_applied)."""

    update_period_s: float = param(1.0, gt=0, le=600, doc="how often the torques are recomputed (a whole "
                                   "multiple of sim.control_period_s)")
    gravity_gradient: bool = param(True, doc="the gravity-gradient torque 3 mu/r^3 (r x I r)")
    drag: DragParams | None = param(None, doc="aerodynamic drag (absent: none)")
    solar_pressure: SolarPressureParams | None = param(None, doc="solar radiation pressure (absent: none)")
    sun: bool = param(True, doc="compute the Sun's direction (the IAU's Earth ephemeris, pyerfa)")
    moon: bool = param(False, doc="compute the Moon's direction (Meeus's lunar theory, pyerfa's moon98) for the "
                       "trace: truth/moon_direction")
    eclipse: bool = param(True, doc="the Earth's cylindrical shadow switches the solar pressure off")
    magnetic_field: MagneticParams | None = param(None, doc="geomagnetic field and residual dipole (absent: none)")
    magnetometer: MagnetometerParams | None = param(None, doc="the magnetometer the desaturation reads "
                                                    "(absent with magnetorquers: an ideal one)")
    magnetorquers: MagnetorquerParams | None = param(None, doc="magnetorquers and their desaturation law")
    facet_half_size_m: list[float] | None = param(None, length=3, doc="half sizes of the box the drag and "
                                                  "pressure act on (default: the bus's box in the model)")
    centre_of_pressure_offset_m: list[float] = param([0.0, 0.0, 0.0], length=3, doc="shift of every facet's "
                                                     "centre from the CoM, body axes")

    def validate(self, path: str) -> None:
        if self.eclipse and not self.sun:
            raise InputError(join(path, "eclipse"), "an eclipse needs the Sun: set sun: true or eclipse: false")
        if self.solar_pressure is not None and not self.sun:
            raise InputError(join(path, "solar_pressure"), "solar pressure needs the Sun: set sun: true")
        if self.magnetorquers is not None and self.magnetic_field is None:
            raise InputError(join(path, "magnetorquers"), "magnetorquers need a field: add environment.magnetic_field")
        if self.magnetometer is not None and self.magnetic_field is None:
            raise InputError(join(path, "magnetometer"), "a magnetometer needs a field: add environment.magnetic_field")
        if self.facet_half_size_m is not None and min(self.facet_half_size_m) <= 0:
            raise InputError(join(path, "facet_half_size_m"), "every half size must be > 0")
