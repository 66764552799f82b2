"""The reaction-wheel plant: the wheels' hinges and motors by name, what their tachometers read,
the wheel torques applied, and the wheels' momentum in the trace."""

from __future__ import annotations

import mujoco
import numpy as np

from testbed.appendages.build import initial_positions
from testbed.plant import Plant, float_writer
from testbed.recording.scene import moving_parts
from testbed.systems.free_bus import FreeBus
from testbed.systems.reaction_wheels.model import ReactionWheelsParams, WheelsParams, motor_names, wheel_names


class WheelDrive:
    """The wheels of a compiled model (`add_wheels`) on `data`: their hinges' speeds and their
    motors, as views of MuJoCo's arrays (which never move: a copy costs a quarter of slicing anew)."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, params: WheelsParams):
        self.array = params.wheel_array()
        count = self.array.count
        dofs = [int(model.joint(name).dofadr[0]) for name in wheel_names(count)]
        motors = [int(model.actuator(name).id) for name in motor_names(count)]
        if dofs != list(range(dofs[0], dofs[0] + count)) or motors != list(range(motors[0], motors[0] + count)):
            raise RuntimeError("the wheels' hinges and motors are not contiguous in the compiled model")
        self.rates = data.qvel[dofs[0]:dofs[0] + count]  # [rad/s] relative to the bus
        self.torques = data.actuator_force[motors[0]:motors[0] + count]  # [N m] the motors applied
        self.write_torques = float_writer(data.ctrl[motors[0]:motors[0] + count])
        self.initial_speeds = params.initial_speeds()

    def start(self) -> None:
        """Set the wheels to their initial speeds (relative to the bus)."""
        self.rates[:] = self.initial_speeds

    def truth(self) -> dict[str, np.ndarray]:
        """`wheel_rate` (n,) [rad/s, relative to the bus] and `wheel_torque` (n,) [N m] the motors applied."""
        return {"wheel_rate": self.rates.copy(), "wheel_torque": self.torques.copy()}

    def derived_signals(self, recorder) -> dict[str, np.ndarray]:
        """`wheel_momentum` (n,) h_i = Js_i Omega_i and `wheel_momentum_body` (3,) A h [N m s]."""
        rates = recorder["truth/wheel_rate"]
        return {"truth/wheel_momentum": self.array.wheel_momentum(rates),
                "truth/wheel_momentum_body": self.array.momentum(rates)}

    def stored_momentum(self) -> float:
        """sum_i Js_i |Omega_i| [N m s]: the momentum the wheels hold, whatever its direction."""
        return float(np.sum(np.abs(self.array.wheel_momentum(self.rates))))

    def speeds_rpm(self) -> list[float]:
        return (self.rates * 60.0 / (2.0 * np.pi)).tolist()


class ReactionWheelPlant(Plant):
    """A free bus with n wheels: command `wheel_torques` (n,) [N m], the motor torque on each wheel
    about its spin axis (the bus takes its reaction); MuJoCo clamps it to the motor's limit
    (ctrlrange). Truth adds the WheelDrive's `wheel_rate` and `wheel_torque`; derived, its
    `wheel_momentum` and `wheel_momentum_body`."""

    def __init__(self, model: mujoco.MjModel, params: ReactionWheelsParams):
        super().__init__(FreeBus(model), [] if params.appendages is None else initial_positions(params.appendages))
        self.wheels = WheelDrive(model, self.data, params)
        self.array = self.wheels.array
        self.actuators = {"body_torque": (3,), "wheel_torques": (self.array.count,)}

    def initialise(self, initial) -> None:
        self.wheels.start()
        super().initialise(initial)

    def wheel_rates(self) -> np.ndarray:
        """Wheel speeds relative to the bus [rad/s], as the tachometers read them."""
        return self.wheels.rates.copy()

    def truth(self) -> dict[str, np.ndarray]:
        return super().truth() | self.wheels.truth()

    def derived_signals(self, recorder) -> dict[str, np.ndarray]:
        return self.wheels.derived_signals(recorder)

    def actuator_state(self) -> dict[str, np.ndarray]:
        return {"wheel_rate": self.wheels.rates.copy()}

    def apply(self, command: dict[str, np.ndarray]) -> None:
        if "body_torque" in command:
            super().apply(command)
        torques = command.get("wheel_torques")
        if torques is not None:
            self.wheels.write_torques(*torques)

    def internal_momentum_body(self) -> np.ndarray:
        """H = sum_i Js_i Omega_i a_i: the wheels' momentum relative to the bus, bus axes [N m s]."""
        return self.array.momentum(self.wheels.rates)

    def momentum_scale(self) -> float:
        """max(|L|, sum_i Js_i |Omega_i|, min_i Js_i Omega_max,i): the stored momentum keeps the
        scale meaningful for wheels whose momenta cancel, and one wheel's momentum at its speed
        limit (the scale of what the array exchanges with the bus) for wheels that start at rest."""
        return max(super().momentum_scale(), self.wheels.stored_momentum(), float(np.min(self.array.momentum_max)))

    def description(self):
        return self.array

    def applied(self) -> dict:
        """The base read-backs (the bus's inertia tensor as compiled, not its principal moments) and
        the initial wheel speeds."""
        bus = self.bus.bus_body_id
        rotation = np.empty(9)
        mujoco.mju_quat2Mat(rotation, self.model.body_iquat[bus])
        rotation = rotation.reshape(3, 3)
        tensor = rotation @ np.diag(self.model.body_inertia[bus]) @ rotation.T
        values = super().applied()
        values.pop("model.inertia_kg_m2", None)
        return values | {"model.inertia_tensor_kg_m2": tensor.tolist(),
                         "model.wheel_speeds_rpm": self.wheels.speeds_rpm()}

    def scene(self) -> dict:
        """The base scene plus the wheels (drawn at their mount, not turning: a balanced wheel's
        angle enters no equation), the panels turning with their recorded hinge angles, and the
        wheels' momentum on the bus."""
        hinges = {} if self.appendages is None else self.appendages.hinge_signals()
        return super().scene() | {"moving_parts": moving_parts(self.model, self.bus.bus_body_id, hinges),
                                  "body_momenta": {"truth/wheel_momentum_body": "wheel_momentum"},
                                  "units": {"wheel_momentum_body": "N m s", "wheel_momentum": "N m s"}}
