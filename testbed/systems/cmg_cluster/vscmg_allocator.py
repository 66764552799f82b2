"""The allocator `vscmg`: the four units as variable-speed CMGs (Schaub and Junkins' weighted law).

Each control tick it solves H' = D b' + C W' (testbed.steering.variable_speed) with the
measured gimbal angles and rotor speeds: D_i = Js_i W_i t_i(b), C_i = Js_i s_i(b), then commands
the gimbal rates b' and the rotor speeds W_cmd <- W_cmd + Tc W' through the rotors' speed loops
(MuJoCo velocity actuators, clipped to model.rotor_speed_range_rpm). The wheel accelerations
are bounded so that W_cmd stays inside pipeline.allocator.rotor_speed_range_rpm, which must lie
inside the rotors' range and hold the speeds the run starts at. Everything else (rate limit,
statistics, fault isolation: the failed unit's columns of D and C zeroed) is the steering
allocators' (testbed.steering.stage). docs/theory/faults.md, "Variable-speed CMGs".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.errors import InputError
from testbed.math.cross import cross3
from testbed.pipeline import stage
from testbed.scenario.schema import join, param
from testbed.steering.result import SteeringResult, status_string, status_code
from testbed.steering.stage import SteeringAllocator, SteeringParams
from testbed.steering.variable_speed import variable_speed_steering

RANGE = "pipeline.allocator.rotor_speed_range_rpm"
RPM = np.pi / 30.0


@dataclass(kw_only=True)
class VscmgParams(SteeringParams):
    rotor_speed_range_rpm: list[float] = param(length=2, gt=0, doc="[min, max] rotor speed the law may command")
    gimbal_weight: float = param(1.0, gt=0, doc="Wg, the gimbal rates' weight")
    # SI units, W weighs squared rates: a wheel's column (Js) is Omega times shorter than a gimbal's
    # (Js Omega), so Ws0 / Wg ~ 1e4 lets the wheels carry a torque near a singular set at gimbal
    # rates of 0.3 rad/s (docs/theory/faults.md, "Variable-speed CMGs")
    wheel_weight: float = param(1e4, gt=0, doc="Ws0, the wheel accelerations' weight at a singular set")
    weight_decay: float = param(100.0, ge=0, doc="mu: Ws = Ws0 exp(-mu det(D D^T) / h^6)")

    def validate(self, path: str) -> None:
        super().validate(path)
        low, high = self.rotor_speed_range_rpm
        if not low < high:
            raise InputError(join(path, "rotor_speed_range_rpm"), f"min {low:g} rpm must be below max {high:g} rpm")


@stage("allocator", "vscmg", VscmgParams)
class VscmgAllocator(SteeringAllocator):
    """Gimbal rates and rotor speeds from Schaub and Junkins' weighted VSCMG law (module doc)."""

    law_name = "pinv"  # the parent's option checks; the law here is variable_speed_steering
    commands = ("gimbal_rates", "rotor_speeds")

    def __init__(self, params: VscmgParams, ctx):
        super().__init__(params, ctx)
        if self.limits is not None:
            raise InputError("pipeline.allocator.gimbal_angle_limits_deg", "vscmg takes no gimbal angle or "
                             "acceleration limits")
        geometry = ctx.description
        motor_range = getattr(geometry, "rotor_speed_range", None)
        if motor_range is None:
            raise InputError("pipeline.allocator.type", "vscmg needs rotors whose speed may change: "
                             "give model.rotor_speed_range_rpm")
        low, high = np.asarray(params.rotor_speed_range_rpm) * RPM
        if low < motor_range[0] * (1 - 1e-12) or high > motor_range[1] * (1 + 1e-12):
            raise InputError(RANGE, f"[{low / RPM:g}, {high / RPM:g}] rpm leaves the rotors' range "
                             f"model.rotor_speed_range_rpm = [{motor_range[0] / RPM:g}, {motor_range[1] / RPM:g}] rpm")
        start = np.asarray(ctx.actuators.get("rotor_rate", [geometry.nominal_rotor_speed]), float)
        outside = np.flatnonzero((start < low) | (start > high))
        if outside.size:
            raise InputError(RANGE, f"rotor {outside[0] + 1} starts at {start[outside[0]] / RPM:g} rpm, outside "
                             f"[{low / RPM:g}, {high / RPM:g}] rpm")
        self.speed_range = (low, high)
        self.speed_command = np.broadcast_to(start, (len(geometry.gimbal_axes),)).copy()
        self.weights = {"gimbal_weight": params.gimbal_weight, "wheel_weight": params.wheel_weight,
                        "decay": params.weight_decay}

    def allocate(self, t, demand, estimate, actuators):
        beta, rotor = actuators["gimbal_angle"], actuators["rotor_rate"]
        torque = np.asarray(demand.get("torque", np.zeros(3)), float)
        omega = np.asarray(estimate.get("omega", np.zeros(3)), float)
        g = self.geometry
        momentum = g.momentum(beta, rotor)
        gyroscopic = cross3(omega, momentum)
        hdot = -(torque + gyroscopic)
        unit = g.unit_jacobian(beta)
        gimbal_columns = unit * (g.spin_inertia * rotor)
        wheel_columns = g.spin_axes(beta).T * g.spin_inertia
        failed = ()
        if self.isolation is not None:
            residual = self.isolation.update(t, self.previous, actuators, self.speed_command)
            self.statistics.update(self.isolation.statistics)
            failed = self.isolation.failed
            gimbal_columns[:, failed] = 0.0
            wheel_columns[:, failed] = 0.0
        low, high = self.speed_range
        bounds = ((low - self.speed_command) / self.period, (high - self.speed_command) / self.period)
        result = variable_speed_steering(gimbal_columns, wheel_columns, hdot, g.h, beta_rate_max=self.rate_max,
                                         wheel_acceleration_bounds=bounds, **self.weights)
        measure = float(np.sqrt(max(np.linalg.det(unit @ unit.T), 0.0)))
        steering = SteeringResult(result.gimbal_rates, result.hdot_delivered, result.scale, measure, 3,
                                  status_string(result.scale < 1.0))
        self._count(steering, beta)
        self.previous = result.gimbal_rates
        self.speed_command = np.clip(self.speed_command + self.period * result.wheel_accelerations, low, high)
        command = {"gimbal_rates": result.gimbal_rates, "rotor_speeds": self.speed_command.copy(),
                   "torque_delivered": -result.hdot_delivered - gyroscopic, "momentum": momentum,
                   "held_momentum": momentum + g.turning_momentum(actuators["gimbal_rate"]),
                   "scale": np.array([result.scale]), "singularity": np.array([measure]),
                   "wheel_weight": np.array([result.wheel_weight]),
                   "status": np.array([float(status_code(steering.status))])}
        if self.isolation is not None:
            command["fault_residual"] = residual
            command["failed_units"] = (~self.isolation.healthy).astype(float)
        return command
