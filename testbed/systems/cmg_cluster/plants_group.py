"""The CMG plants of a batch's live worlds on (N, ...) arrays (`CmgPlant.group_form`).

Each tick the worlds' qpos, qvel, act and clocks are read into (N, ...) arrays once (one
`np.concatenate` per array: the state does not change between the allocator's read-out, the
command and the trace sample), the gimbal servos' per-tick arithmetic (gimbal_servo.py) runs on them, and
each world's ctrl row is written back whole. The jumps that refine a tick (jump_refinement.py)
are found on the commands as arrays; the physics stays one `mj_step` call per world
(docs/validation.md "Measured times": a thread pool, `mujoco.rollout` and `mujoco.batch` were no
faster on this machine). Faults, tachometer faults, the total angular momentum (MuJoCo's own
read-out) and the signals of energy, orbit and appendages stay per world.

Every row is its world's own plant's, bit for bit where NumPy's sin and cos round as the math
module's (they do on the machines measured; elsewhere an ulp of the angle's sine, tests allow
1e-12 relative): the servo's arithmetic is written in its scalar order, one operation per operation.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from testbed.batch.plant_group import PerWorldPlants
from testbed.systems.cmg_cluster.faults import FAULT_CODES
from testbed.systems.cmg_cluster.gimbal_servo import FeedForwardServo


# fewer worlds than this cost less one by one: the group's NumPy calls cost about as much as
# 3 worlds' scalar servo ticks (flagship: read, command and truth 22 against 23 us a world-tick at 4 worlds)
GROUP_FROM_WORLDS = 4


def cmg_plant_group(plants: list, steps: int):
    """The group of the worlds' CmgPlants: `CmgPlantGroup` when there are GROUP_FROM_WORLDS or
    more and they share one state layout (the same joints and actuators at the same addresses)
    and one servo model, else `PerWorldPlants` (each world's own plant, as a single run steps it)."""
    first = plants[0]
    layout = _layout(first)
    if len(plants) < GROUP_FROM_WORLDS or any(_layout(plant) != layout or type(plant.servo) is not type(first.servo)
                                               for plant in plants[1:]):
        return PerWorldPlants(plants, steps)
    return CmgPlantGroup(plants, steps)


def _layout(plant) -> tuple:
    """What must be alike for one column of an (N, ...) buffer to be the same quantity in every world."""
    bus, model = plant.bus, plant.model
    return (model.nq, model.nv, model.na, model.nu, bus.bus_body_id, bus.omega_dofs, bus.quat_coords, bus.gimbal_qpos, bus.gimbal_qvel,
            bus.rotor_qvel, bus.gimbal_act, bus.gimbal_ctrl, bus.gimbal_servo_ctrl,
            tuple(bus.rotor_actuator_ids.tolist()), tuple(bus.torque_actuator_ids.tolist()))


def _limit_row(limit, units: int) -> np.ndarray:
    """A servo's rate limit (None, one value or one per gimbal) [rad/s] as (units,), inf for none."""
    return np.full(units, np.inf) if limit is None else np.broadcast_to(np.asarray(limit, dtype=float), (units,)).copy()


class CmgPlantGroup(PerWorldPlants):
    """The CMG plants of the live worlds, read and commanded on (N, n) arrays (module docstring).
    The servos' state lives here while the batch runs; `settle(row)` writes it back into that
    world's servo and jump refinement, before its run's last truth sample."""

    def __init__(self, plants: list, steps: int):
        super().__init__(plants, steps)
        self.steps = steps
        first = self.plants[0]
        bus, self.units = first.bus, first.bus.units
        self.feedforward = isinstance(first.servo, FeedForwardServo)
        self._cols = (bus.omega_dofs, bus.quat_coords, bus.gimbal_qpos, bus.gimbal_qvel, bus.rotor_qvel,
                      bus.gimbal_act, slice(bus.qvel_adr + 3, bus.qvel_adr + 6))
        self._rates_ctrl, self._servo_ctrl = bus.gimbal_ctrl, bus.gimbal_servo_ctrl
        self._rotor_ctrl, self._torque_ctrl = bus.rotor_actuator_ids, bus.torque_actuator_ids
        self._fast_truth = not any(p.record_energy or p.surroundings is not None or p.appendages is not None
                                   for p in self.plants)
        self._gather()
        self._fresh = False  # whether qpos, qvel, act and time hold the worlds' state now

    def _gather(self) -> None:
        """The per-world views, and the servos' and jump refinements' state as rows."""
        plants, n = self.plants, self.units
        datas = [plant.data for plant in plants]
        self._datas, self._models = datas, [plant.model for plant in plants]
        self._qpos, self._qvel, self._act = ([d.qpos for d in datas], [d.qvel for d in datas],
                                             [d.act for d in datas])
        self._ctrl_views = [d.ctrl for d in datas]
        # each world's physics of a tick at its timestep, and finer (CmgPlant.tick_steps); a world in
        # orbit or with unbalanced rotors steps itself (CmgPlant.stepper, its refinement its own)
        self.own_steps = [plant.imbalance is not None or plant.surroundings is not None for plant in plants]
        self._coarse, self._fine = map(list, zip(*[(plant.stepper(self.steps), None) if own
                                                   else plant.tick_steps(self.steps)
                                                   for plant, own in zip(plants, self.own_steps)]))
        count = len(plants)
        model = plants[0].model
        self.ctrl = np.array([d.ctrl for d in datas], dtype=float).reshape(count, model.nu)
        servos = [plant.servo for plant in plants]
        self.current = np.array([s._current for s in servos], dtype=float).reshape(count, n)
        self.previous = np.array([s._previous for s in servos], dtype=float).reshape(count, n)
        self.applied_at = np.array([np.nan if s._applied_at is None else s._applied_at for s in servos], dtype=float)
        self.jammed = np.zeros((count, n), dtype=bool)
        for row, servo in enumerate(servos):
            self.jammed[row, servo._jammed] = True
        self.rate_limit = np.array([_limit_row(s.rate_limit, n) for s in servos]).reshape(count, n)
        jumps = [plant.jumps for plant in plants]
        self.jump_last = np.array([j.last for j in jumps], dtype=float).reshape(count, n)
        self.jump_until = np.array([-np.inf if own else j.until for own, j in zip(self.own_steps, jumps)])
        self.jump_threshold = np.array([np.inf if own else j.threshold for own, j in zip(self.own_steps, jumps)])
        self.jump_window = np.array([j.window for j in jumps])
        self.faulty = [row for row, plant in enumerate(plants) if plant.faults is not None]
        if self.feedforward:
            self._gather_feedforward(servos)

    def _gather_feedforward(self, servos: list) -> None:
        n, count = self.units, len(servos)
        gains = np.array([[g[1:] for g in s._gains] for s in servos], dtype=float).reshape(count, n, 4)
        self.gain, self.kv_q, self.jp, self.jq = (gains[..., k] for k in range(4))
        self.delta = np.array([s._delta for s in servos], dtype=float).reshape(count, n)
        self.predicted = np.array([s._predicted for s in servos], dtype=float).reshape(count, n)
        self.torque = np.array([s._torque for s in servos], dtype=float).reshape(count, n)
        self.last_angle = np.array([s._last_angle for s in servos], dtype=float).reshape(count, n)
        self.last_rate = np.array([s._last_rate for s in servos], dtype=float).reshape(count, n)
        self.mean_before = np.array([s._mean_before for s in servos], dtype=float).reshape(count, n)
        self.m1 = np.array([s.m1 for s in servos])[:, None]
        self.ramp = np.array([s.m2 / (2.0 * s.period) for s in servos])[:, None]
        self.bus_response = np.array([s._bus_response for s in servos], dtype=float)  # (N, 3, 3)
        self.spin_zero = np.array([s.geometry.spin_axes_zero for s in servos], dtype=float)  # (N, n, 3)
        self.turn = np.array([s.geometry.turn_axes for s in servos], dtype=float)
        self.spin_inertia = np.array([s.geometry.spin_inertia for s in servos], dtype=float).reshape(count, n)
        self.torque_limit = np.array([np.inf if s.torque_limit is None else s.torque_limit for s in servos])[:, None]
        self.torque_limited = np.array([s.torque_limit is not None for s in servos])[:, None]
        self.any_torque_limit = bool(self.torque_limited.any())

    # --- rows ---------------------------------------------------------------------------
    def keep(self, rows: np.ndarray) -> None:
        """Only the worlds at `rows` go on (their state rows kept, the others' dropped)."""
        super().keep(rows)
        for name in ("ctrl", "current", "previous", "applied_at", "jammed", "rate_limit", "jump_last",
                     "jump_until", "jump_threshold", "jump_window") + (
                ("gain", "kv_q", "jp", "jq", "delta", "predicted", "torque", "last_angle", "last_rate",
                 "mean_before", "m1", "ramp", "bus_response", "spin_zero", "turn", "spin_inertia", "torque_limit",
                 "torque_limited") if self.feedforward else ()):
            setattr(self, name, getattr(self, name)[rows])
        self._datas, self._models = [self._datas[i] for i in rows], [self._models[i] for i in rows]
        self._qpos, self._qvel, self._act = ([self._qpos[i] for i in rows], [self._qvel[i] for i in rows],
                                             [self._act[i] for i in rows])
        self._ctrl_views = [self._ctrl_views[i] for i in rows]
        self._coarse, self._fine = [self._coarse[i] for i in rows], [self._fine[i] for i in rows]
        self.own_steps = [self.own_steps[i] for i in rows]
        if self._fresh:
            self.qpos, self.qvel, self.act, self.time = (self.qpos[rows], self.qvel[rows], self.act[rows],
                                                         self.time[rows])
        self.faulty = [row for row, plant in enumerate(self.plants) if plant.faults is not None]

    def settle(self, row: int) -> None:
        """Write row's servo and jump-refinement state back into its world's objects (what its
        plant's `truth()` and a later single step read)."""
        plant = self.plants[row]
        servo, jumps = plant.servo, plant.jumps
        servo._current, servo._previous = self.current[row].tolist(), self.previous[row].tolist()
        applied = float(self.applied_at[row])
        servo._applied_at = None if np.isnan(applied) else applied
        if not self.own_steps[row]:
            jumps.last, jumps.until = self.jump_last[row].tolist(), float(self.jump_until[row])
        if self.feedforward:
            servo._delta, servo._predicted = self.delta[row].tolist(), self.predicted[row].tolist()
            servo._torque = self.torque[row].tolist()
            servo._last_angle, servo._last_rate = self.last_angle[row].tolist(), self.last_rate[row].tolist()
            servo._mean_before = self.mean_before[row].tolist()

    # --- read-outs -----------------------------------------------------------------------
    def _read(self) -> None:
        """The worlds' qpos, qvel, act and clocks as (N, ...) arrays, once between steps (new
        arrays each time: the read-outs handed out are views of them)."""
        if self._fresh:
            return
        count = len(self._datas)
        self.qpos = np.concatenate(self._qpos).reshape(count, -1)
        self.qvel = np.concatenate(self._qvel).reshape(count, -1)
        self.act = np.concatenate(self._act).reshape(count, -1)
        self.time = np.array([d.time for d in self._datas])
        self._fresh = True

    def held_command(self) -> np.ndarray:
        """Each world's gimbal-rate command held over the period that ends now (IntVelocityServo.held_command)."""
        self._read()
        return np.where((self.applied_at == self.time)[:, None], self.previous, self.current)

    def truth(self) -> dict:
        """Each world's `CmgPlant.truth()` (the same keys, in order), (N, ...)."""
        self._read()
        omega, quat, angle, rate, rotor, _, _ = self._cols
        if self._fast_truth:
            signals = {"omega": self.qvel[:, omega], "quat": self.qpos[:, quat],
                       "angular_momentum_world": self.plants[0].bus.total_angular_momenta_world(
                           self._models, self._datas, np.empty((len(self._datas), 3)))}
            signals.update(gimbal_angle=self.qpos[:, angle], gimbal_rate=self.qvel[:, rate],
                           gimbal_rate_command=self.held_command(), rotor_rate=self.qvel[:, rotor])
            if self.plants[0].faults is not None:
                signals["fault"] = np.array([np.zeros(self.units) if p.faults is None else p.faults.codes
                                             for p in self.plants])
            return signals
        signals = super().truth()  # energy, orbit or appendages: each world's own, the servos' command from here
        signals["gimbal_rate_command"] = self.held_command()
        return signals

    def actuator_state(self) -> dict:
        """Each world's `CmgPlant.actuator_state()` (a faulty tachometer as it reads), (N, n)."""
        self._read()
        _, _, angle, rate, rotor, _, _ = self._cols
        rates = self.qvel[:, rate]
        if self.faulty:
            rates = rates.copy()  # not the truth's
        for row in self.faulty:
            faults = self.plants[row].faults
            if faults.sensors_faulty:
                rates[row] = faults.tachometer(rates[row])
        return {"gimbal_angle": self.qpos[:, angle], "gimbal_rate": rates, "rotor_rate": self.qvel[:, rotor]}

    # --- commands ------------------------------------------------------------------------
    def apply(self, command: dict) -> dict:
        """Each world's row of `command` to its plant (CmgPlant.apply); row -> the exception of the
        worlds whose servo could not take it."""
        try:
            return self._apply(command)
        except (ValueError, TypeError, IndexError) as exc:  # a command of the wrong shape: every world's
            return {row: exc for row in range(len(self.plants))}

    def _apply(self, command: dict) -> dict:
        self._read()
        count, plants = len(self.plants), self.plants
        ctrl = self.ctrl
        torque = command.get("body_torque")
        if torque is not None:  # the base class's actuator, asked for only when commanded
            ctrl[:, self._torque_ctrl] = np.broadcast_to(np.asarray(torque, dtype=float), (count, 3))
            for plant in plants:
                plant.torqued = True
        for row in self.faulty:
            self._update_faults(row)
        speeds = command.get("rotor_speeds")
        if speeds is not None:  # variable-speed rotors (MuJoCo clips to the speed range)
            speeds = np.array(np.broadcast_to(np.asarray(speeds, dtype=float), (count, self.units)))
            for row in self.faulty:  # a spun-down rotor's motor is off
                codes = plants[row].faults.codes
                speeds[row] = np.where(codes == FAULT_CODES["spin_down"], 0.0, speeds[row])
            ctrl[:, self._rotor_ctrl] = speeds
        failures = self._servo(command.get("gimbal_rates"))
        for view, row in zip(self._ctrl_views, ctrl):
            view[:] = row
        return failures

    def _update_faults(self, row: int) -> None:
        """Start world row's faults due now (FaultInjector.update); a fault that changed its servo
        (stuck, rate_limit) or its ctrl (spin_down) is read back into the rows."""
        plant = self.plants[row]
        faults = plant.faults
        due = len(faults.pending)
        faults.update(plant.data.time)
        if len(faults.pending) == due:
            return
        servo = plant.servo
        self.jammed[row] = False
        self.jammed[row, servo._jammed] = True
        self.rate_limit[row] = _limit_row(servo.rate_limit, self.units)
        self.ctrl[row, self._rotor_ctrl] = plant.data.ctrl[self._rotor_ctrl]

    def _servo(self, rates) -> dict:
        """The servos' take of this tick's gimbal-rate command (None: hold), then, for the
        feedforward servo, its observer update and held motor torque (FeedForwardServo.apply);
        written into the ctrl rows. Row -> the failure of a world whose angles are infinite
        (where the scalar servo's math.cos raises)."""
        self.previous = self.current
        self.applied_at = self.time
        if rates is not None:
            self.current = np.where(self.jammed, 0.0, np.asarray(rates, dtype=float))
        if not self.feedforward:
            self.ctrl[:, self._rates_ctrl] = self.current
            return {}
        with np.errstate(all="ignore"):
            self._feedforward()
        angle = self.last_angle
        if math.isfinite(float(angle.sum())):
            return {}
        return {int(row): ValueError("math domain error") for row in np.flatnonzero(np.isinf(angle).any(axis=1))}

    def _feedforward(self) -> None:
        """FeedForwardServo.apply and _angle_correction on the rows, operation for operation (a
        rate limit of inf clips nothing, to the bit)."""
        _, _, angle_cols, rate_cols, _, act_cols, _ = self._cols
        limit = self.rate_limit
        command = np.minimum(np.maximum(self.current, -limit), limit)
        followed = np.minimum(np.maximum(self.previous, -limit), limit)
        rate, angle, setpoint = self.qvel[:, rate_cols], self.qpos[:, angle_cols], self.act[:, act_cols]
        # _angle_correction: the PD-weighted mean angles' second difference, times D
        m1, ramp = self.m1, self.ramp
        mean_last = self.last_angle + self.last_rate * m1 + (rate - self.last_rate) * ramp
        mean_next = angle + rate * m1 + (command - rate) * ramp
        second = mean_next - 2.0 * mean_last + self.mean_before
        self.mean_before, self.last_angle, self.last_rate = mean_last, angle, rate
        correction = self._angle_sensitivity_times(angle, second)
        delta_now = self.predicted + self.gain * (rate - followed)
        coming = 2.0 * delta_now - self.delta + correction
        self.delta = delta_now
        torque = self.kv_q * command - self.jp * (angle - setpoint) - self.jq * rate - coming
        if self.any_torque_limit:
            limit = self.torque_limit
            applied = np.minimum(np.maximum(torque, -limit), limit)
            # the motor's shortfall counts as disturbance not compensated (no wind-up)
            coming = np.where(self.torque_limited, coming + torque - applied, coming)
            torque = applied
        self.predicted, self.torque = coming, torque
        self.ctrl[:, self._servo_ctrl] = np.concatenate([self.current, torque], axis=1)

    def _angle_sensitivity_times(self, angle: np.ndarray, x: np.ndarray) -> np.ndarray:
        """FeedForwardServo.angle_sensitivity_times on the rows: D x [N m], (N, n), for x (N, n)
        [rad]; the turned axes as ClusterGeometry.turned_axes_floats computes them, every sum in
        the scalar code's order (written out: NumPy's reductions add in another order)."""
        c, s = np.cos(angle)[..., None], np.sin(angle)[..., None]
        e, t = self.spin_zero, self.turn  # (N, n, 3)
        spin = c * e + s * t
        columns = c * t - s * e  # -s e + c t, to the bit
        h = self.spin_inertia * self.qvel[:, self._cols[4]]
        terms = (h * x)[..., None] * columns  # h_j x_j J_j, summed over j in order
        total = terms[:, 0]
        for j in range(1, self.units):
            total = total + terms[:, j]
        parts = self.bus_response * total[:, None, :]  # R sum_j h_j x_j J_j, each row's three products
        u = (parts[..., 0] + parts[..., 1] + parts[..., 2])[:, None, :]
        along = columns * u
        w = self.qvel[:, None, self._cols[6]]
        turning = spin * w
        return -h * ((along[..., 0] + along[..., 1] + along[..., 2])
                     + (turning[..., 0] + turning[..., 1] + turning[..., 2]) * x)

    # --- physics -------------------------------------------------------------------------
    def step_calls(self) -> list:
        """The calls that step each world one control tick: a world whose gimbal command jumped by
        more than its threshold since the last tick steps this tick and the ticks of its window
        finer (JumpRefinement.advance), the others at the model's timestep."""
        self._read()
        commands = self.ctrl[:, self._rates_ctrl].copy()
        jumped = np.abs(commands - self.jump_last).max(axis=1) > self.jump_threshold
        self.jump_last = commands
        self.jump_until = np.where(jumped, self.time + self.jump_window, self.jump_until)
        refine = self.time < self.jump_until - 1e-9 * self.jump_window
        self._fresh = False
        if not refine.any():
            return self._coarse
        return [functools.partial(plant.jumps.advance_fine, fine) if finer else advance
                for finer, plant, advance, fine in zip(refine.tolist(), self.plants, self._coarse, self._fine)]
