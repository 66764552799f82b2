"""The MuJoCo truth as the runner sees it: step, read true signals, apply commands.

A `Plant` owns a compiled model and its `MjData`; the base class reads a free-flying bus
through `testbed.systems.free_bus.FreeBus`, and each system's plant (testbed/systems/<name>/) adds
its own joints and actuators. Only the sensor stage and the trace read `truth()`;
controllers get `actuator_state()` (what encoders and tachometers on the actuators report)
and their own measurements.
"""

from __future__ import annotations

import functools
import math
import struct

import mujoco
import numpy as np

from testbed.appendages.joints import AppendageJoints
from testbed.scenario.shipped_files import INTEGRATORS

INTEGRATOR_NAMES = {int(getattr(mujoco.mjtIntegrator, member)): name for name, member in INTEGRATORS.items()}


# MuJoCo writes its warnings to MUJOCO_LOG.TXT in the working directory unless a callback takes
# them: keep the last one for the run's error message instead.
_mujoco_warnings: list[str] = []
mujoco.set_mju_user_warning(lambda message: _mujoco_warnings.append(" ".join(str(message).split())))


def float_writer(view: np.ndarray):
    """A function that writes its float arguments into `view` (a view of one of MuJoCo's
    arrays, kept): `write(*values)` does `view[:] = values`. Where the view is contiguous
    the values are packed straight into its memory, twice as fast as numpy's conversion of
    a short list (a command is written every control tick)."""
    if view.dtype == np.float64 and view.flags.c_contiguous:
        return functools.partial(struct.Struct(f"{view.size}d").pack_into, memoryview(view).cast("B"), 0)

    def write(*values):
        view[:] = values

    return write


def _step_in_surroundings(plant, advance) -> None:
    """MuJoCo's steps, then the surroundings' update at the new time (Plant.stepper)."""
    advance()
    plant.surroundings.update(plant)


class SimulationDiverged(RuntimeError):
    """MuJoCo hit a bad acceleration or a non-finite state; carries the time it happened."""

    def __init__(self, time: float, reason: str):
        self.time = time
        super().__init__(f"simulation diverged at t = {time:.6g} s: {reason}")


class Plant:
    """A compiled model with a free-flying body named `bus`, driven by ideal body torques."""

    def __init__(self, bus, appendage_start=()):
        """`appendage_start`: the appendages' coordinates at the start (testbed.appendages.build
        .initial_positions), when the model has panels or slosh masses."""
        # addresses of the free bus (FreeBus) or the system's own equivalent, which declares
        # state_views(data) (views of the bus rate and attitude, or None) and applied() (its read-back fields)
        self.bus = bus
        self.model = bus.model
        self.data = mujoco.MjData(self.model)
        self.appendages = AppendageJoints.find(self.model, self.data)
        self.appendage_start = list(appendage_start)
        # the bus's rate and attitude as views of MuJoCo's arrays, which never move (a FreeBus):
        # each read-out copies a view, a quarter of the cost of slicing data's array anew
        views = bus.state_views(self.data)  # None: no one free bus (the bus says how to read it)
        self._omega_now, self._quat_now = views if views is not None else (None, None)
        # MuJoCo resets the state (or zeroes the control) on these and carries on: we stop.
        self._bad = [(w, self.data.warning[w]) for w in (
            mujoco.mjtWarning.mjWARN_BADQACC, mujoco.mjtWarning.mjWARN_BADQVEL,
            mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADCTRL)]
        # the same four counters as one view of MuJoCo's array, read once a step
        kinds = sorted(int(kind) for kind, _ in self._bad)
        if kinds != list(range(kinds[0], kinds[0] + len(kinds))):
            raise RuntimeError(f"MuJoCo's bad-state warnings are not contiguous: {kinds}")
        self._bad_counts = self.data.warning.number[kinds[0]:kinds[-1] + 1]
        self._qvel = self.data.qvel
        self.record_energy = False  # the run's plan turns it on where energy can be conserved (run_core.conservation)
        self.surroundings = None  # the orbit and its torques (testbed.environment.surroundings), set by the runner
        self.torqued = False  # whether a body torque (an external one) was ever applied

    # --- state -------------------------------------------------------------------------
    @property
    def time(self) -> float:
        return float(self.data.time)

    def omega(self) -> np.ndarray:
        """Body-frame angular velocity of the bus."""
        return self._omega_now.copy() if self._omega_now is not None else self.bus.body_omega(self.data)

    def quat(self) -> np.ndarray:
        """Bus attitude (w, x, y, z), body to world."""
        return self._quat_now.copy() if self._quat_now is not None else self.bus.body_quat(self.data)

    def angular_momentum_world(self) -> np.ndarray:
        """Total angular momentum of the whole spacecraft about its CoM, world frame."""
        return self.bus.total_angular_momentum_world(self.data)

    def locked_inertia(self) -> np.ndarray:
        """Inertia of the whole spacecraft, joints locked, about its CoM, body axes, now."""
        mujoco.mj_forward(self.model, self.data)
        return self.bus.system_inertia(self.data)

    def kinetic_energy(self) -> float:
        """Total kinetic energy 1/2 qvel' M(q) qvel at the current state [J]."""
        mujoco.mj_fwdPosition(self.model, self.data)  # M at the current q, not the step's start
        mujoco.mj_energyVel(self.model, self.data)
        return float(self.data.energy[1])

    # Whether the plant holds a momentum device (rotors, wheels, CMGs) whose momentum
    # `internal_momentum_body` reports, for magnetorquers to unload; a rigid body holds none.
    holds_internal_momentum = False

    def internal_momentum_body(self) -> np.ndarray:
        """Momentum of the moving parts relative to the bus, body frame (none for a rigid body)."""
        return np.zeros(3)

    def momentum_scale(self) -> float:
        """Scale for relative momentum drift: max(|L|, stored internal momentum)."""
        return max(float(np.linalg.norm(self.angular_momentum_world())),
                   float(np.linalg.norm(self.internal_momentum_body())), 1e-300)

    # --- stepping ----------------------------------------------------------------------
    def step(self, nstep: int) -> None:
        """Advance `nstep` physics steps; raise SimulationDiverged instead of MuJoCo's reset."""
        t0 = self.data.time  # MuJoCo's reset on a bad state also resets data.time
        mujoco.mj_step(self.model, self.data, nstep)
        self.check_state(t0, nstep)
        if self.surroundings is not None:  # the torques of the orbit at the new time, held until the next update
            self.surroundings.update(self)

    def stepper(self, nstep: int):
        """A function that advances `nstep` physics steps without looking for a bad state:
        a loop that calls it every control tick calls `check_state` once every few ticks
        instead. A plant whose `step` does more than mj_step is stepped by `step` itself."""
        if type(self).step is not Plant.step:
            return functools.partial(self.step, nstep)
        if self.surroundings is not None:
            return functools.partial(_step_in_surroundings, self, functools.partial(mujoco.mj_step, self.model,
                                                                                    self.data, nstep))
        return functools.partial(mujoco.mj_step, self.model, self.data, nstep)

    def check_state(self, t0: float, nstep: int) -> None:
        """Raise SimulationDiverged if MuJoCo met a bad state (and reset it) or a velocity is
        not finite, naming the window of `nstep` steps from time t0 [s] since the last check."""
        # plain floats: a sum is NaN or infinite when any velocity is (or overflows)
        if any(self._bad_counts.tolist()) or not math.isfinite(sum(self._qvel.tolist())):
            self._diverged(t0, nstep)

    def _diverged(self, t0: float, nstep: int) -> None:
        for kind, stat in self._bad:
            if stat.number:
                said = f" ({_mujoco_warnings[-1]})" if _mujoco_warnings else ""
                _mujoco_warnings.clear()
                raise SimulationDiverged(t0, f"MuJoCo {kind.name}: NaN, Inf or huge value "
                                             f"within {nstep} steps after this time{said}")
        raise SimulationDiverged(t0, "non-finite velocity")

    # --- what subclasses refine ---------------------------------------------------------
    def initialise(self, initial) -> None:
        self.bus.set_free_joint_state(self.data, initial.omega, initial.quat)
        self.place_appendages()
        mujoco.mj_forward(self.model, self.data)

    def step_rates(self) -> dict[str, float]:
        """Rates [rad/s] whose angle a step must resolve, known before the run (testbed.accuracy.
        step_size): the fastest pole of the joints' springs and dampers, when the model has appendages."""
        if self.appendages is None:
            return {}
        return {"fastest appendage mode": self.appendages.fastest_mode(self.model)}

    def place_appendages(self) -> None:
        """Deflect the panels and slosh masses as the scenario starts them (before mj_forward)."""
        if self.appendages is not None and self.appendage_start:
            self.appendages.set_positions(self.appendage_start)

    def truth(self) -> dict[str, np.ndarray]:
        signals = {"omega": self.omega(), "quat": self.quat(),
                   "angular_momentum_world": self.angular_momentum_world()}
        if self.record_energy:
            signals["kinetic_energy"] = np.array([self.kinetic_energy()])
        if self.surroundings is not None:
            signals.update(self.surroundings.signals)
        if self.appendages is not None:
            signals.update(self.appendages.truth())
        return signals

    def derived_signals(self, recorder) -> dict[str, np.ndarray]:
        """Signals computed from the recorded truth (vectorised, off the loop), a chunk of samples
        at a time as the run goes: `recorder[key]` and `recorder.time` are the chunk's rows (a
        `testbed.recording.recorder.Chunk`), so each row must follow from the same row's values."""
        return {}

    def actuator_state(self) -> dict[str, np.ndarray]:
        return {}

    # Command keys this plant's actuators take, with their shapes; other keys of a command are diagnostics.
    actuators = {"body_torque": (3,)}

    # The plants of many worlds stepped in lockstep, on (N, ...) arrays: a class taking (plants, steps
    # a tick) like testbed.batch.plant_group.PerWorldPlants, which a batch uses when this is None.
    group_form = None

    def apply(self, command: dict[str, np.ndarray]) -> None:
        """Body torque on the bus [N m, body axes]; a plant with other actuators extends this."""
        torque = command.get("body_torque")
        if torque is not None:
            self.bus.set_body_torque(self.data, torque)
            self.torqued = True

    def external_wrench(self) -> bool:
        """Whether a force from outside the system acted on it (a body torque applied, the environment's
        torques): then neither momentum nor energy is conserved (the accuracy guard reads it). A system adds its own."""
        return self.torqued or (self.surroundings is not None and self.surroundings.params is not None)

    def tracking_monitor(self, command_key: str | None):
        """(running reduction, figure(state), what it measures) of how far the actuators missed
        the command `command_key` (the accuracy guard's tracking monitor), or None: none here."""
        return None

    def description(self):
        """Static design data controllers may use (e.g. an actuator cluster's geometry)."""
        return None

    def applied(self) -> dict:
        """Scenario fields as this plant runs them, by dotted path, read back from the compiled
        model and the state `initialise` left (testbed.campaign.applied_values compares them with what a
        campaign drew): the step and integrator, the initial rate and attitude of the bus, the
        panels' mass, stiffness and damping, and what the bus read-outs add (`FreeBus.applied`).
        A system adds its own fields."""
        omega = self.omega()
        values = {"sim.dt_s": float(self.model.opt.timestep),
                  "sim.integrator": INTEGRATOR_NAMES[int(self.model.opt.integrator)],
                  "initial.omega_rad_s": omega.tolist(), "initial.omega_deg_s": np.degrees(omega).tolist(),
                  "initial.quat": self.quat().tolist()}
        if self.appendages is not None:
            values |= self.appendages.applied(self.model)
        return values | self.bus.applied()

    def scene(self) -> dict:
        """What the 3D view draws: the bus box half sizes (from its first box geom) [m]."""
        bus = self.bus.bus_body_id
        boxes = [g for g in range(self.model.ngeom)
                 if self.model.geom_bodyid[g] == bus and self.model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX]
        half = self.model.geom_size[boxes[0]] if boxes else [0.5] * 3
        scale = 1.0 / max(self.momentum_scale(), 1e-9)  # per N m s: the longest arrow about 1
        return {"bus_half_size": list(map(float, half)), "momentum_scale": scale}
