"""The CMG spacecraft as a plant: gimbal-rate servos and ideal torques, cluster read-outs.

`CmgRhombus` knows the compiled model's gimbal and rotor joints and servos by name;
`CmgPlant` is what the runner steps and the sensors read; its gimbal servo
(gimbal_servo.py) takes the gimbal-rate commands.
"""

import functools

import mujoco
import numpy as np

from testbed.errors import InputError
from testbed.systems.free_bus import FreeBus
from testbed.math.quaternion import quat_conj, quat_rotate
from testbed.plant import Plant
from testbed.recording.scene import moving_parts
from testbed.steering.singularity_type import DEGENERATE, ELLIPTIC, HYPERBOLIC, KIND_NAMES
from testbed.systems.cmg_cluster.cluster import ClusterGeometry, unit_count, unit_names
from testbed.systems.cmg_cluster.faults import FAULT_CODES, FaultInjector
from testbed.systems.cmg_cluster.gimbal_servo import FeedForwardServo, IntVelocityServo
from testbed.systems.cmg_cluster.plants_group import cmg_plant_group
from testbed.systems.cmg_cluster.jump_refinement import JUMP_FRACTION, JUMP_NO_LIMIT_RAD_S, JumpRefinement
from testbed.systems.cmg_cluster.units import INITIAL_KEY, unit_actuator_names
from testbed.systems.cmg_cluster.reduced_model import CmgMassModel
from testbed.systems.cmg_cluster.rotor_imbalance import RotorImbalance
from testbed.systems.cmg_cluster.servo_tracking import ServoMiss, servo_miss
from testbed.systems.cmg_cluster.momentum_envelope import (remaining_cluster_surfaces, singular_surface_points,
                                                           surface_color, surface_name)

# the momentum view's marks of the singular states the path met: hyperbolic cyan, elliptic magenta, degenerate white
SINGULAR_KIND_COLORS = {HYPERBOLIC: [40, 200, 235], ELLIPTIC: [225, 40, 210], DEGENERATE: [245, 245, 245]}
ENVELOPE_DIRECTIONS = 1500  # directions per surface in the trace's momentum view (testbed envelope: 4000)


def evenly_spaced(addresses) -> slice:
    """The slice that picks `addresses` (evenly spaced, increasing) out of a MuJoCo array: a
    read through it copies nothing, and a view through it can be kept and written."""
    addresses = [int(a) for a in addresses]
    steps = {b - a for a, b in zip(addresses, addresses[1:])}
    if len(steps) != 1 or min(steps) <= 0:
        raise ValueError(f"addresses {addresses} are not evenly spaced")
    return slice(addresses[0], addresses[-1] + 1, steps.pop())


MOMENTUM_NEWTON_STEPS = 30


class CmgRhombus(FreeBus):
    """The compiled CMG spacecraft, known by joint and actuator names."""

    def __init__(self, model):
        super().__init__(model)
        # the gimbal inertias too, so the allocator can report the cluster's momentum in full
        self.geometry = ClusterGeometry.from_model(model).with_gimbal_inertia(
            CmgMassModel.from_model(model).cmg_inertia)
        self.units = unit_count(model)
        self.gimbal_names, self.rotor_names = unit_names(self.units)
        gimbal_servos, rotor_servos, gimbal_motors = unit_actuator_names(self.units)
        gimbal_joints = [model.joint(n) for n in self.gimbal_names]
        rotor_joints = [model.joint(n) for n in self.rotor_names]
        self.gimbal_qpos_adr = np.array([j.qposadr[0] for j in gimbal_joints])
        self.gimbal_qvel_adr = np.array([j.dofadr[0] for j in gimbal_joints])
        self.rotor_qpos_adr = np.array([j.qposadr[0] for j in rotor_joints])
        self.rotor_qvel_adr = np.array([j.dofadr[0] for j in rotor_joints])
        self.gimbal_actuator_ids = np.array([model.actuator(n).id for n in gimbal_servos])
        self.gimbal_act_adr = model.actuator_actadr[self.gimbal_actuator_ids]
        self.rotor_actuator_ids = np.array([model.actuator(n).id for n in rotor_servos])
        names = {model.actuator(i).name for i in range(model.nu)}
        # the feedforward servo's motors, when the model has them
        self.gimbal_motor_ids = np.array([model.actuator(n).id for n in gimbal_motors if n in names], dtype=int)
        self.initial_key_id = model.key(INITIAL_KEY).id
        # the same addresses as slices (MuJoCo lays the CMGs out alike)
        self.gimbal_qpos = evenly_spaced(self.gimbal_qpos_adr)
        self.gimbal_qvel = evenly_spaced(self.gimbal_qvel_adr)
        self.rotor_qvel = evenly_spaced(self.rotor_qvel_adr)
        self.gimbal_act = evenly_spaced(self.gimbal_act_adr)
        self.gimbal_ctrl = evenly_spaced(self.gimbal_actuator_ids)
        # the servos' rate commands, then the motors' torques when the model has them
        self.gimbal_servo_ctrl = evenly_spaced(np.concatenate([self.gimbal_actuator_ids, self.gimbal_motor_ids]))
        rotor = self.rotor_actuator_ids[0]  # the speed range the builder gave every rotor loop
        if model.actuator_ctrllimited[rotor]:
            self.geometry.rotor_speed_range = tuple(float(v) for v in model.actuator_ctrlrange[rotor])
        # every dof that is not the bus free joint belongs to a gimbal or a rotor
        bus_dofs = set(range(self.qvel_adr, self.qvel_adr + 6))
        self.internal_dofs = np.array([i for i in range(model.nv) if i not in bus_dofs])

    def gimbal_angles(self, data):
        """Gimbal angles beta [rad], (n,)."""
        return data.qpos[self.gimbal_qpos].copy()

    def gimbal_rates(self, data):
        """Gimbal rates beta' [rad/s], (n,)."""
        return data.qvel[self.gimbal_qvel].copy()

    def rotor_rates(self, data):
        """Rotor speeds relative to their gimbals Omega [rad/s], (n,)."""
        return data.qvel[self.rotor_qvel].copy()

    def set_gimbal_rate_command(self, data, rates):
        """Command gimbal rates [rad/s]; the servo integrates them into an angle set-point."""
        data.ctrl[self.gimbal_actuator_ids] = np.asarray(rates, dtype=float)

    def set_rotor_speed_command(self, data, speeds):
        """Command relative rotor speeds [rad/s]."""
        data.ctrl[self.rotor_actuator_ids] = np.asarray(speeds, dtype=float)

    def initialise(self, data, omega0_body, quat0, beta0=None, rotor_speed=None):
        """Reset to keyframe "initial" (beta0 and nominal rotor speed from build), then set the
        bus attitude quat0 and body rate omega0_body, optionally other gimbal angles beta0
        and rotor speeds; servo activations = gimbal angles, gimbal commands 0; mj_forward."""
        mujoco.mj_resetDataKeyframe(self.model, data, self.initial_key_id)
        if beta0 is not None:
            beta0 = np.asarray(beta0, dtype=float)
            if beta0.shape != (self.units,) or not np.all(np.isfinite(beta0)):
                raise InputError("beta0", f"expected {self.units} finite angles, got {beta0}")
            data.qpos[self.gimbal_qpos_adr] = beta0
        if rotor_speed is not None:
            speeds = np.broadcast_to(np.asarray(rotor_speed, dtype=float), (self.units,))
            if not np.all(np.isfinite(speeds)):
                raise InputError("rotor_speed", f"expected finite speeds, got {rotor_speed}")
            data.qvel[self.rotor_qvel_adr] = speeds
            self.set_rotor_speed_command(data, speeds)
        # the servo set-point is its activation: it must start at the actual angle
        data.act[self.gimbal_act_adr] = data.qpos[self.gimbal_qpos_adr]
        data.qvel[self.gimbal_qvel_adr] = 0.0
        self.set_gimbal_rate_command(data, np.zeros(self.units))
        self.set_free_joint_state(data, omega0_body, quat0)
        mujoco.mj_forward(self.model, data)

    def internal_momentum_body(self, data):
        """Angular momentum of the gimbals and rotors (and any wheels and appendages) relative
        to the bus, bus frame [N m s].

        The bus-rotation row of the mass matrix times the joint rates: sum_k I_k w_rel,k +
        m_k r_k x v_rel,k (the second zero for gimbals, rotors and wheels, whose CoMs lie on their
        joint axes; a panel's or slosh mass's about the bus origin). Includes the gimbal-rate
        terms, unlike the spin-only H(beta).
        """
        self.refresh(data)
        mass_matrix = np.zeros((self.model.nv, self.model.nv))
        mujoco.mj_fullM(self.model, data, mass_matrix)
        a = self.qvel_adr + 3
        rows = mass_matrix[a:a + 3][:, self.internal_dofs]
        return rows @ data.qvel[self.internal_dofs]


class CmgPlant(Plant):
    """Truth adds gimbal angles and rates, the gimbal-rate command the servos held, rotor
    rates and the cluster momentum H (body frame)."""

    holds_internal_momentum = True
    group_form = staticmethod(cmg_plant_group)  # many worlds' plants on (N, ...) arrays

    def __init__(self, model, params, control_period: float, appendage_start=()):
        """`params`: the validated parameters `model` was built from (CmgRhombusParams or
        CmgClusterParams: its servo model and limits, cancel_initial_momentum); `control_period`
        [s]: how long each command is held; `appendage_start`: Plant's. The commands take one
        value per unit."""
        super().__init__(CmgRhombus(model), appendage_start)
        units = self.bus.units
        self.actuators = {"body_torque": (3,), "gimbal_rates": (units,), "rotor_speeds": (units,)}
        self.geometry = self.bus.geometry
        # what the encoders and tachometers read, as views of MuJoCo's arrays (which never move):
        # a copy of a view costs a quarter of slicing data's array anew, at every trace sample and
        # every control tick of a steering allocator
        self._gimbal_angle = self.data.qpos[self.bus.gimbal_qpos]
        self._gimbal_rate = self.data.qvel[self.bus.gimbal_qvel]
        self._rotor_rate = self.data.qvel[self.bus.rotor_qvel]
        self.cancel_initial_momentum = params.cancel_initial_momentum
        rate_limit = None if params.gimbal_rate_limit_deg_s is None else np.radians(params.gimbal_rate_limit_deg_s)
        if params.servo_model == "feedforward":
            self.servo = FeedForwardServo(self.bus, model, self.data, params.servo_natural_frequency_rad_s,
                                          params.servo_damping_ratio, control_period, rate_limit,
                                          params.gimbal_torque_limit_nm)
        else:
            self.servo = IntVelocityServo(self.bus, self.data, rate_limit)
        self.faults = FaultInjector(self, params.faults) if params.faults else None
        unbalanced = any(params.rotor_static_imbalance_kg_m) or any(params.rotor_dynamic_imbalance_kg_m2)
        self.imbalance = RotorImbalance(self.bus, model, self.data, params.rotor_static_imbalance_kg_m,
                                        params.rotor_dynamic_imbalance_kg_m2) if unbalanced else None
        self.control_period, self.rate_limit = control_period, rate_limit
        threshold = JUMP_NO_LIMIT_RAD_S if rate_limit is None else JUMP_FRACTION * float(np.min(rate_limit))
        self.jumps = JumpRefinement(model, self.data, self.data.ctrl[evenly_spaced(self.bus.gimbal_actuator_ids)],
                                    threshold, control_period)

    # --- what the accuracy guard reads (testbed/accuracy/) -------------------------------
    def external_wrench(self) -> bool:
        """Whether a force from outside the spacecraft acts: the environment's, or the unbalanced
        rotors' jitter (applied to the bus as xfrc_applied, rotor_imbalance.py)."""
        return super().external_wrench() or self.imbalance is not None

    def step_rates(self) -> dict[str, float]:
        """Rates [rad/s] whose angle a step must resolve, known before the run: the rotor speed of
        unbalanced rotors (the jitter's wrench turns with the rotor angle; a balanced rotor's angle
        enters no equation), the gimbal-rate limit, when set, and the appendages' (Plant's)."""
        rates = super().step_rates()
        if self.imbalance is not None:
            rates["rotor speed of the unbalanced rotors"] = float(np.max(np.abs(self.bus.rotor_rates(self.data))))
        if self.rate_limit is not None:
            rates["gimbal rate limit"] = float(np.max(self.rate_limit))
        return rates

    def tracking_monitor(self, command_key: str | None):
        """(reduction, figure(state), what it is) of the gimbal servo's miss (servo_tracking.py)
        when the allocator commands gimbal rates, else None."""
        if command_key != "gimbal_rates":
            return None
        return (ServoMiss(self.control_period, self.rate_limit), servo_miss,
                "the gimbal servo missed its held command, beyond the jumps it was handed, by")

    def step(self, nstep: int) -> None:
        """`nstep` physics steps, finer after a gimbal-command jump (jump_refinement.py); with rotor
        imbalance, its wrench renewed before each (rotor_imbalance.py)."""
        if self.imbalance is None:
            return self.jumps.advance(functools.partial(Plant.step, self, nstep),
                                      functools.partial(Plant.step, self, nstep * self.jumps.factor))
        t0 = self.data.time
        # in orbit, the environment's held wrench is added to the imbalance's (both are xfrc_applied)
        self.imbalance.step(nstep, None if self.surroundings is None else self.surroundings.applied_world)
        self.check_state(t0, nstep)
        if self.surroundings is not None:
            self.surroundings.update(self)

    def stepper(self, nstep: int):
        """Plant.stepper's fast path (mj_step, checked every few ticks; in orbit, the surroundings'
        update after it) unless the rotors are unbalanced; a tick after a gimbal-command jump is
        stepped finer (jump_refinement.py). The unbalanced rotors' wrench is renewed at its own
        half steps (rotor_imbalance.py), so their ticks are not."""
        if self.imbalance is None:
            if self.surroundings is not None:
                coarse, fine = super().stepper(nstep), super().stepper(nstep * self.jumps.factor)
            else:
                coarse, fine = self.tick_steps(nstep)
            return self.jumps.stepper(coarse, fine)
        return functools.partial(self.step, nstep)

    def tick_steps(self, nstep: int) -> tuple:
        """(coarse, fine): MuJoCo's `nstep` physics steps, and `factor` times as many (at the
        timestep JumpRefinement.advance_fine sets), with no check for a bad state and nothing
        else: the steps of a plant neither in orbit nor with unbalanced rotors."""
        return (functools.partial(mujoco.mj_step, self.model, self.data, nstep),
                functools.partial(mujoco.mj_step, self.model, self.data, nstep * self.jumps.factor))

    def initialise(self, initial) -> None:
        self.bus.initialise(self.data, initial.omega, initial.quat)
        if self.appendage_start:  # the keyframe holds them at rest
            self.place_appendages()
            mujoco.mj_forward(self.model, self.data)
        if self.cancel_initial_momentum:
            self._cancel_momentum()
        self.servo.start(self.data)  # at the gimbal angles the case starts from

    def _cancel_momentum(self) -> None:
        """Newton steps on the gimbal angles, b <- b - J(b)^+ L (J = dH/db, SEEDS §004 eq. (18);
        the pseudo-inverse takes the least change), until the total angular momentum L (body
        axes, from MuJoCo: spin, gimbal and bus inertia at b) is zero to 1e-13 of sum |h_i|.
        The servo set-points follow the angles, so the servos start without an error."""
        beta = self.bus.gimbal_angles(self.data)
        scale = float(np.sum(self.geometry.rotor_momentum))
        for _ in range(MOMENTUM_NEWTON_STEPS):
            momentum = quat_rotate(quat_conj(self.quat()), self.angular_momentum_world())
            if np.linalg.norm(momentum) <= 1e-13 * scale:
                return
            beta = beta - np.linalg.pinv(self.geometry.jacobian(beta)) @ momentum
            self.data.qpos[self.bus.gimbal_qpos_adr] = beta
            self.data.act[self.bus.gimbal_act_adr] = beta
            mujoco.mj_forward(self.model, self.data)
        raise InputError("model.cancel_initial_momentum",
                         f"no gimbal set near model.gimbal_angles_deg holds the bus's momentum "
                         f"{np.linalg.norm(momentum):.4g} N m s (cluster h = {self.geometry.h:g} N m s each)")

    def applied(self) -> dict:
        """The base read-backs plus the initial gimbal angles and the rotor momentum h as built."""
        return super().applied() | {"model.gimbal_angles_deg": np.degrees(self.bus.gimbal_angles(self.data)).tolist(),
                                    "model.rotor_momentum_nms": self.geometry.h}

    def truth(self) -> dict[str, np.ndarray]:
        signals = super().truth()
        signals.update(gimbal_angle=self._gimbal_angle.copy(), gimbal_rate=self._gimbal_rate.copy(),
                       gimbal_rate_command=self.servo.held_command(self.data), rotor_rate=self._rotor_rate.copy())
        if self.faults is not None:
            signals["fault"] = self.faults.codes.copy()  # each unit's active fault (faults.FAULT_CODES)
        return signals

    def derived_signals(self, recorder) -> dict[str, np.ndarray]:
        """Cluster spin momentum H(beta, Omega), body axes (SEEDS §004 eq. 15), and the singularity
        measure sqrt(det(J J^T)) of the true gimbal angles, from the recorded histories, computed
        after the run in one vectorised pass; in orbit also the share of the momentum envelope H
        takes (`envelope_share`: the gauge max_u u.H / S(u), 1 on the envelope; momentum_gauge.py),
        at the environment's update instants."""
        beta = recorder["truth/gimbal_angle"]
        momentum = self.geometry.momentum(beta, recorder["truth/rotor_rate"])
        signals = {"truth/cmg_momentum": momentum,
                   "truth/singularity_measure": self.geometry.singularity_measure(beta)[:, None]}
        if self.surroundings is not None and len(momentum):  # in orbit: how full the cluster is
            signals["truth/envelope_share"] = self._envelope_share(recorder.time, momentum)
        return signals

    def _envelope_share(self, times, momentum) -> np.ndarray:
        """The gauge of H on the rows at the surroundings' update instants, NaN between (a gauge
        costs ~1 ms: at every sample of a fast trace it would cost more than the loop)."""
        period = self.surroundings.period
        on_grid = np.abs(times / period - np.round(times / period)) < 1e-9 * max(1.0, float(np.max(times)) / period)
        share = np.full((len(times), 1), np.nan)
        if on_grid.any():
            share[on_grid, 0] = self.geometry.momentum_gauge(momentum[on_grid])[0]
        return share

    def actuator_state(self) -> dict[str, np.ndarray]:
        """What the gimbal encoders and the gimbal and rotor tachometers report (a faulty
        gimbal-rate tachometer as it reads: faults.py)."""
        rate = self._gimbal_rate.copy()
        if self.faults is not None and self.faults.sensors_faulty:
            rate = self.faults.tachometer(rate)
        return {"gimbal_angle": self._gimbal_angle.copy(), "gimbal_rate": rate,
                "rotor_rate": self._rotor_rate.copy()}

    def apply(self, command: dict[str, np.ndarray]) -> None:
        if "body_torque" in command:  # the base class's one actuator, asked for only when commanded
            super().apply(command)
        if self.faults is not None:
            self.faults.update(self.data.time)
        speeds = command.get("rotor_speeds")
        if speeds is not None:  # variable-speed rotors (MuJoCo clips to the speed range)
            speeds = np.asarray(speeds, dtype=float)
            if self.faults is not None:  # a spun-down rotor's motor is off
                speeds = np.where(self.faults.codes == FAULT_CODES["spin_down"], 0.0, speeds)
            self.bus.set_rotor_speed_command(self.data, speeds)
        self.servo.apply(self.data, command.get("gimbal_rates"))

    def internal_momentum_body(self) -> np.ndarray:
        return self.bus.internal_momentum_body(self.data)

    def momentum_scale(self) -> float:
        """max(|L|, |H|, sum_i |h_i|): the stored rotor momentum sum_i Js_i |Omega_i| keeps the
        scale meaningful for a zero-momentum gimbal set (H = 0, e.g. (45, -45, -45, 45) deg)."""
        stored = float(np.sum(self.geometry.spin_inertia * np.abs(self.bus.rotor_rates(self.data))))
        return max(super().momentum_scale(), stored)

    def description(self):
        return self.geometry

    def scene(self) -> dict:
        """The base scene plus the cluster: the gimbal frames and rotors from the compiled model's
        geoms, turning with the recorded gimbal angles, each rotor's momentum h_i along its spin
        axis and the total H on the bus; and the momentum view: the envelope and the 2^(n-1) - 1 internal
        singular surfaces (momentum_envelope.py, gimbal axes and h_i from the model) with the run's
        H(t) coloured by sqrt(det(J J^T)) (its largest value for n unit columns is (n/3)^(3/2))."""
        model = self.model
        hinges = {name: ("truth/gimbal_angle", i) for i, name in enumerate(self.bus.gimbal_names)}
        if self.appendages is not None:  # the panels turn with their recorded hinge angles
            hinges |= self.appendages.hinge_signals()
        parts = moving_parts(model, self.bus.bus_body_id, hinges)
        rotors = {f"{gimbal}/{rotor}": i for i, (gimbal, rotor) in enumerate(zip(self.bus.gimbal_names,
                                                                                self.bus.rotor_names))}
        for part in parts:
            i = rotors.get(part["entity"])
            if i is not None:
                axis = model.jnt_axis[model.joint(self.bus.rotor_names[i]).id]  # the spin axis, rotor frame
                part["arrows"] = [{"vector": (self.geometry.rotor_momentum[i] * axis).tolist(), "label": f"h{i + 1}"}]
        g, units = self.geometry, self.bus.units
        surfaces = singular_surface_points(None, ENVELOPE_DIRECTIONS, g.rotor_momentum, g.gimbal_axes)
        drawn = [{"name": surface_name(p), "points": points, "color": surface_color(p)} for p, points in surfaces.items()]
        for unit in sorted({fault.unit for fault in (self.faults.planned if self.faults else ())}):
            # the cluster a fault leaves (momentum_envelope.remaining_cluster_surfaces)
            remaining = remaining_cluster_surfaces(g.gimbal_axes, [unit - 1], ENVELOPE_DIRECTIONS, g.rotor_momentum)
            drawn += [{"name": f"without_unit{unit}/{surface_name(p)}", "points": points, "color": surface_color(p)}
                      for p, points in remaining.items()]
        return super().scene() | {
            "body_momenta": {"truth/cmg_momentum": "cmg_momentum"},
            "units": {"cmg_momentum": "N m s", "singularity_measure": ""},
            "moving_parts": parts,
            "momentum_space": {
                "title": "cluster momentum H [N m s]: envelope, singular surfaces, H(t)",
                "surfaces": drawn,
                "path": "truth/cmg_momentum", "measure": "truth/singularity_measure",
                "measure_range": [0.0, (units / 3.0) ** 1.5],
                # where the path met each kind of singular state (the steering stage's Bedrossian test)
                "marks": {"signal": "allocator/singularity_type", "entity": "singular",
                          "kinds": {code: {"name": KIND_NAMES[code], "color": color}
                                    for code, color in SINGULAR_KIND_COLORS.items()}}}}
