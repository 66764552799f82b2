"""The units of a single-gimbal CMG spacecraft, whatever its array: the fields every CMG system's
`model:` block shares (`CmgUnitsParams`) and `compile_units`, which applies them with MjSpec to a
spec that holds the units by name: their placement, rotor and gimbal inertias, the gimbal-rate and
rotor-speed servo gains, limits, friction and, for the `feedforward` servo, one motor per gimbal
(gimbal_servo.py says what each servo model does). The seed's rhombus (testbed/systems/cmg_rhombus)
and the clusters of model.py build their units with it.
"""

from dataclasses import dataclass
from typing import Literal

import mujoco
import numpy as np

from testbed.errors import InputError
from testbed.math.validation import check_principal_inertia
from testbed.scenario.shipped_files import compile_model
from testbed.scenario.schema import UNIT_RANGES, join, param
from testbed.systems.cmg_cluster.cluster import ROTOR_SPEED_NUMERIC, unit_names
from testbed.systems.cmg_cluster.faults import FaultEvent, check_faults



def unit_actuator_names(units: int) -> tuple[tuple[str, ...], tuple[str, ...], tuple[str, ...]]:
    """(gimbal-rate servos, rotor-speed loops, gimbal motors) of a cluster of `units`, by name;
    the gimbal motors are kept for servo_model feedforward only."""
    numbers = range(1, units + 1)
    return (tuple(f"gimbal_rate{i}" for i in numbers), tuple(f"rotor_speed{i}" for i in numbers),
            tuple(f"gimbal_torque{i}" for i in numbers))


INITIAL_KEY = "initial"

# RK4 stays accurate and stable for the servo modes when (rate x dt) is well below its
# stability limit 2.8; divergence was measured at w_n dt ~ 1 and good tracking at 0.3-0.6.
MAX_SERVO_OMEGA_DT = 0.7
MAX_DT_OVER_ROTOR_TAU = 0.5


@dataclass(kw_only=True)
class CmgUnitsParams:
    """What every single-gimbal CMG spacecraft's `model:` block holds beside its bus inertia and
    its array: the rotors, gimbals, servos, limits and faults of its units. A subclass declares its
    units' initial `gimbal_angles_deg` and says how many units there are (`unit_count`).

    mass_kg: the bus alone (the units add theirs).
    rotor_momentum_nms: h, spin momentum of one rotor at the nominal speed; the rotor spin
        inertia is Js = h / Omega.
    rotor_transverse_ratio: rotor transverse inertia / spin inertia (0.5 for a thin disk).
    gimbal_inertia_kg_m2: gimbal frame principal inertia about (gimbal axis, spin axis at
        beta = 0, third axis).
    servo_model: `intvelocity` (MuJoCo's integrated-velocity servo alone, stiff) or
        `feedforward` (the same servo, softer, plus a motor torque held over each control
        tick that brings the gimbal rate to the command by the tick's end); gimbal_servo.py.
    servo_natural_frequency_rad_s, servo_damping_ratio: the servo's PD loop, w_n (its
        bandwidth) and zeta; kp = J w_n^2, kv = 2 zeta w_n J with J the inertia about the
        gimbal axis (gimbal frame + rotor transverse), so the servo's dynamics do not change
        with the inertias.
    gimbal_torque_limit_nm: the most torque a gimbal motor gives (PD and feed-forward
        together; MuJoCo clamps the joint's actuator torque), None: unlimited.
    gimbal_rate_limit_deg_s: the largest gimbal-rate command a servo follows (commands are
        clipped to it), None: unlimited.
    rotor_speed_time_constant_s: tau of the rotor speed loop; kv = Js / tau.
    cancel_initial_momentum: start a zero-momentum spacecraft whatever its initial rate: the
        gimbals start at the set nearest gimbal_angles_deg whose cluster momentum cancels the
        bus's, so the total angular momentum is zero (CmgPlant.initialise).
    rotor_speed_range_rpm: the speeds the rotor motors can hold, [min, max] around
        rotor_speed_rpm; given, the rotors may be commanded other speeds (allocator vscmg).
    gimbal_friction_nm, gimbal_damping_nms_rad: the gimbal bearings' Coulomb friction (MuJoCo's
        joint frictionloss) and viscous friction (joint damping), both between gimbal and bus;
        the servo holds the commanded rate against them.
    faults: timed hardware faults of the units (faults.py, docs/theory/faults.md), one per unit.
    """

    mass_kg: float = param(1000.0, gt=0)
    rotor_momentum_nms: float = param(50.0, gt=0, doc="h of each rotor at nominal speed")
    rotor_speed_rpm: float = param(6000.0, ge=1.0, le=1e6)
    rotor_transverse_ratio: float = param(0.6, ge=0.5, doc="Jt / Js of the rotor (>= 0.5 for a rotor)")
    rotor_mass_kg: float = param(10.0, gt=0)
    gimbal_mass_kg: float = param(5.0, gt=0)
    gimbal_inertia_kg_m2: list[float] = param([0.03, 0.02, 0.02], length=3, gt=0)
    servo_model: Literal["intvelocity", "feedforward"] = param("intvelocity")
    servo_natural_frequency_rad_s: float = param(316.0, gt=0)
    servo_damping_ratio: float = param(1.0, gt=0)
    gimbal_torque_limit_nm: float | None = param(None, gt=0)
    gimbal_rate_limit_deg_s: float | None = param(None, gt=0)
    rotor_speed_time_constant_s: float = param(0.02, gt=0)
    cancel_initial_momentum: bool = param(False, doc="move the initial gimbal angles so that the total momentum is 0")
    rotor_speed_range_rpm: list[float] | None = param(None, length=2, gt=0, doc=(
        "[min, max] speed the rotor motors can hold (the speed loops clip their command to it); "
        "None: fixed-speed rotors"))
    gimbal_friction_nm: float = param(0.0, ge=0, doc="Coulomb friction torque of each gimbal bearing (MuJoCo frictionloss)")
    gimbal_damping_nms_rad: float = param(0.0, ge=0, doc="viscous friction of each gimbal bearing (MuJoCo joint damping)")
    faults: list[FaultEvent] = param([], doc="timed unit faults: [{at_s, unit, kind, ...}] (docs/theory/faults.md)")

    def unit_count(self) -> int:
        """How many units the array has."""
        raise NotImplementedError

    def validate(self, path: str) -> None:
        check_principal_inertia(self.gimbal_inertia_kg_m2, join(path, "gimbal_inertia_kg_m2"))
        check_faults(self.faults, self.unit_count(), join(path, "faults"))
        if self.rotor_speed_range_rpm is not None:
            low, high = self.rotor_speed_range_rpm
            if not low <= self.rotor_speed_rpm <= high:
                raise InputError(join(path, "rotor_speed_range_rpm"), f"[{low:g}, {high:g}] rpm must hold the "
                                 f"nominal rotor_speed_rpm = {self.rotor_speed_rpm:g}")
        low, high = UNIT_RANGES["_kg_m2"]
        spin_inertia = self.rotor_momentum_nms / self.rotor_speed
        if not low <= spin_inertia <= high:  # the rotor MuJoCo would build (a singular mass matrix beyond)
            raise InputError(join(path, "rotor_momentum_nms"), f"{self.rotor_momentum_nms:g} N m s at "
                             f"{self.rotor_speed_rpm:g} rpm is a rotor spin inertia of {spin_inertia:.3g} kg m^2, "
                             f"outside [{low:g}, {high:g}] kg m^2")
        for i, angle in enumerate(self.gimbal_angles_deg or []):
            # a gimbal angle is periodic; far beyond a turn the float keeps no fraction of a
            # degree (at 1e308 MuJoCo stops the run at its first step as diverged)
            if not abs(angle) <= 360.0:
                raise InputError(join(path, f"gimbal_angles_deg[{i}]"), f"{angle:g} deg is more than a turn: give "
                                 "the same orientation within [-360, 360] deg")

    @property
    def rotor_speed(self) -> float:
        """Nominal rotor speed Omega [rad/s]."""
        return self.rotor_speed_rpm * np.pi / 30.0


@dataclass
class UnitBuild:
    """One unit as compile_units places and sizes it: its position [m] (bus frame), its gimbal
    frame (3, 3) (columns: gimbal axis g_i, spin axis at beta = 0 e_i, g_i x e_i), its rotor
    momentum at the nominal speed [N m s], rotor and gimbal-frame masses [kg] and the gimbal frame's
    principal inertia about (g_i, e_i, g_i x e_i) [kg m^2]."""

    position: np.ndarray
    frame: np.ndarray
    rotor_momentum: float
    rotor_mass: float
    gimbal_mass: float
    gimbal_inertia: list[float]


def compile_units(spec, params: CmgUnitsParams, dt: float, units: list[UnitBuild],
                  gimbal_angles_deg) -> mujoco.MjModel:
    """Apply `units` and the common fields of `params` (rotor speed and shape, servos, limits,
    friction) to a spec that holds the units' bodies, joints and actuators by name (unit_names,
    unit_actuator_names), and compile it; gimbal_angles_deg: the initial angles."""
    omega_rotor = params.rotor_speed
    ratio = params.rotor_transverse_ratio
    tau = params.rotor_speed_time_constant_s
    if dt / tau > MAX_DT_OVER_ROTOR_TAU:
        raise InputError("model.rotor_speed_time_constant_s",
                         f"{tau} s is too short for timestep {dt} s under RK4")
    gimbals, rotors = unit_names(len(units))
    gimbal_servos, rotor_servos, gimbal_motors = unit_actuator_names(len(units))
    for i, unit in enumerate(units):
        spin_inertia = unit.rotor_momentum / omega_rotor
        rotor_inertia = np.array([ratio, ratio, 1.0]) * spin_inertia  # rotor spin axis = local z
        gimbal_inertia = np.asarray(unit.gimbal_inertia, float)
        gimbal_axis_inertia = gimbal_inertia[0] + rotor_inertia[0]  # rotor transverse about g
        kp, kv = servo_gains(params, dt, gimbal_axis_inertia)
        rotor_kv = spin_inertia / tau
        gimbal = spec.body(gimbals[i])
        gimbal.pos = unit.position
        # gimbal frame: x = g_i (hinge axis in the XML), y = e_i (rotor spin), z = g_i x e_i
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, np.asarray(unit.frame, float).ravel())
        gimbal.quat = quat
        gimbal.mass = unit.gimbal_mass
        gimbal.inertia = gimbal_inertia
        gimbal.ipos = np.zeros(3)
        rotor = spec.body(rotors[i])
        rotor.mass = unit.rotor_mass
        rotor.inertia = rotor_inertia
        rotor.ipos = np.zeros(3)

        servo = spec.actuator(gimbal_servos[i])
        servo.gainprm = _with_first(servo.gainprm, [kp])
        servo.biasprm = _with_first(servo.biasprm, [0.0, -kp, -kv])
        speed = spec.actuator(rotor_servos[i])
        speed.gainprm = _with_first(speed.gainprm, [rotor_kv])
        speed.biasprm = _with_first(speed.biasprm, [0.0, 0.0, -rotor_kv])
        if params.rotor_speed_range_rpm is not None:
            speed.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
            speed.ctrlrange = np.asarray(params.rotor_speed_range_rpm) * np.pi / 30.0
        _apply_limits(spec, params, gimbals[i], gimbal_servos[i])
        if params.gimbal_friction_nm or params.gimbal_damping_nms_rad:
            joint = spec.joint(gimbals[i])
            joint.frictionloss = params.gimbal_friction_nm
            joint.damping = [params.gimbal_damping_nms_rad, 0.0, 0.0]  # MuJoCo 4: the linear coefficient first
        if params.servo_model != "feedforward":
            spec.delete(spec.actuator(gimbal_motors[i]))  # the intvelocity servo has no motor

    spec.numeric(ROTOR_SPEED_NUMERIC).data = [omega_rotor]
    motors = len(units) if params.servo_model == "feedforward" else 0
    _write_initial_key(spec, np.radians(gimbal_angles_deg), omega_rotor, motors)
    return compile_model(spec)


def servo_gains(params: CmgUnitsParams, dt: float, gimbal_axis_inertia: float):
    """(kp, kv) of the integrated-velocity gimbal servo: the closed loop
    J b'' + kv b' + kp b = kp b_cmd has natural frequency w_n and damping ratio zeta.

    kv damps the absolute gimbal rate (not the rate error), so a sinusoidal rate command of
    frequency w is tracked with a relative error of about 2 zeta w / w_n (0.4 % at 0.1 Hz
    for the defaults); a steady rate is tracked exactly, with a constant angle lag. The
    feedforward servo adds kv times the command to its held torque (gimbal_servo.py)."""
    w_n, zeta = params.servo_natural_frequency_rad_s, params.servo_damping_ratio
    if w_n * dt > MAX_SERVO_OMEGA_DT:
        raise InputError("model.servo_natural_frequency_rad_s",
                         f"w_n dt = {w_n * dt:.3f} exceeds {MAX_SERVO_OMEGA_DT}: "
                         "RK4 would be inaccurate or unstable")
    return gimbal_axis_inertia * w_n**2, 2.0 * zeta * w_n * gimbal_axis_inertia


def _apply_limits(spec, params: CmgUnitsParams, gimbal_name: str, servo_name: str) -> None:
    """The physical limits of a gimbal: the motor's torque (MuJoCo clamps the sum of the
    actuator torques on the joint) and the rate command (clipped to the servo's ctrlrange)."""
    limited = mujoco.mjtLimited.mjLIMITED_TRUE
    if params.gimbal_torque_limit_nm is not None:
        joint = spec.joint(gimbal_name)
        joint.actfrclimited = limited
        joint.actfrcrange = [-params.gimbal_torque_limit_nm, params.gimbal_torque_limit_nm]
    if params.gimbal_rate_limit_deg_s is not None:
        servo = spec.actuator(servo_name)
        servo.ctrllimited = limited
        servo.ctrlrange = np.radians([-params.gimbal_rate_limit_deg_s, params.gimbal_rate_limit_deg_s])


def _with_first(array, values):
    """Copy of `array` with its first entries replaced by `values`."""
    out = np.array(array, dtype=float)
    out[:len(values)] = values
    return out


def _write_initial_key(spec, beta0, omega_rotor, motors=0):
    """Keyframe "initial": bus at rest at the origin, gimbals at beta0 with servo activations
    equal to beta0 (so the servos start without a position error), rotors at nominal speed,
    the `motors` gimbal motors (feedforward servo) at zero torque."""
    key = spec.key(INITIAL_KEY)
    qpos = [0, 0, 0, 1, 0, 0, 0]
    qvel = [0.0] * 6
    for b in beta0:
        qpos += [b, 0.0]
        qvel += [0.0, omega_rotor]
    key.qpos = qpos
    key.qvel = qvel
    key.act = list(beta0)
    key.ctrl = [0.0] * 3 + [0.0] * len(beta0) + [0.0] * motors + [omega_rotor] * len(beta0)
