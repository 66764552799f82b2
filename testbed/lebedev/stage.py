"""Lebedev (1976) spin control from ONE rate gyro: the observer and the control law as stages.

- estimator `lebedev`: the observer z' = A z + l (y - C z) + F(z) + u (eq. 4.6), gain
  l = T^-1 L placing eig(A - l C) at `poles_per_s`, preceded by the start-up phase of
  section 3: for t < startup_s the body is uncontrolled and the *linear* observer
  z' = A z + l (y - C z) (eq. 3.1) runs from z = 0; its state then initialises (4.6).
- law `lebedev`: M_i = I_i k_i z_i (eq. 4.7) with z = w_hat - (0, 0, Omega) (eq. 4.1), zero
  torque while the estimator reports the loop open. Task 1 spins the body up to Omega about
  its major axis z; Task 2 (section 5) detumbles it "through" an admissible residual spin
  Omega* (the same law built with Omega = Omega*).

Design data flow: the law owns the task (Omega, gains) and publishes Omega; the estimator
reads it, the sensing axis p (C = p', eq. 4.3) the single-axis sensor publishes, and the
key under which the allocator reports the torque it delivered (all through
`StageContext.stages`), and checks observability (eq. 4.4-4.5) before the run. Causality: at sample k the observer has
integrated over [t_(k-1), t_k] with the input u = M / I that was held over that interval (u
from the torque the allocator reports delivered) and the gyro held at y_(k-1)
(`measurement_hold: zero_order`) or interpolated from y_(k-1) to y_k (`linear`), so z(t_k)
uses no information from after t_k. The samples come every `sim.estimator_period_s`, which
may be shorter than the law's period.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass
from typing import Literal

import numpy as np

from testbed.errors import InputError
from testbed.lebedev.batched import LebedevEstimates, LebedevTorques
from testbed.lebedev.end_momentum import check_end_momentum_held
from testbed.lebedev.momentum import check_momentum_observable, idle_polar_angles
from testbed.math.cross import cross3
from testbed.math.rk4 import check_rk4_stable
from testbed.lebedev.observer import LebedevObserver, check_gains, check_observer_poles, lebedev_torque, output_error
from testbed.lebedev.validity import ErrorGrowth
from testbed.pipeline import MethodFailed, require_free_body, stage
from testbed.scenario.schema import join, param

# Relative size of products of inertia the principal-axis model (eq. 1.2) may ignore.
PRINCIPAL_AXIS_TOLERANCE = 1e-3
# Least eigenvalue of the filter's start information, relative to its largest, taken as non-zero.
START_RCOND = 1e-9


@contextlib.contextmanager
def scenario_fields(names: dict[str, str]):
    """Re-raise the math module's InputErrors under the scenario's dotted field paths."""
    try:
        yield
    except InputError as exc:
        raise InputError(names.get(exc.field, exc.field), exc.reason) from None


def principal_axes_moments(inertia: np.ndarray, field: str = "model.inertia_kg_m2") -> np.ndarray:
    """(Ix, Iy, Iz) of a 3x3 inertia whose body axes are principal (Lebedev 1976, eq. 1.2)."""
    inertia = np.asarray(inertia, float)
    moments = np.diag(inertia).copy()
    products = np.abs(inertia - np.diag(moments)).max()
    if products > PRINCIPAL_AXIS_TOLERANCE * moments.min():
        raise InputError(field, f"body axes are not principal (largest product of inertia {products:.3g} kg m^2); "
                                "the Lebedev model needs Euler's equations in principal axes")
    return moments


# --- the control law (eq. 4.7) -----------------------------------------------------------

@dataclass(kw_only=True)
class LebedevLawParams:
    task: Literal["spin", "detumble"] = param("spin", doc="Task 1 spin-up / Task 2 detumble (section 5)")
    spin_rate_deg_s: float | None = param(None, ge=-3600, le=3600, doc="task spin: the wanted spin Omega about z")
    residual_rate_deg_s: float | None = param(None, gt=0, le=3600, doc="task detumble: admissible residual spin Omega*")
    gains_per_s: list[float] = param(length=3, doc="k1, k2, k3 of M_i = I_i k_i z_i; A + K must be stable")

    def validate(self, path: str) -> None:
        wanted, other = (("spin_rate_deg_s", "residual_rate_deg_s") if self.task == "spin"
                         else ("residual_rate_deg_s", "spin_rate_deg_s"))
        if getattr(self, wanted) is None:
            raise InputError(join(path, wanted), f"is required for task {self.task}")
        if getattr(self, other) is not None:
            raise InputError(join(path, other), f"does not apply to task {self.task} (give {wanted})")
        if self.omega_ref == 0.0:
            raise InputError(join(path, wanted), "must be non-zero: one gyro cannot observe a body "
                                                 "with Omega = 0 (det W ~ Omega^3, eq. 4.5)")

    @property
    def omega_ref(self) -> float:
        """Omega (task spin) or Omega* (task detumble) [rad/s] about body z."""
        value = self.spin_rate_deg_s if self.task == "spin" else self.residual_rate_deg_s
        return float(np.radians(value))

    @property
    def rate_key(self) -> str:
        return "spin_rate_deg_s" if self.task == "spin" else "residual_rate_deg_s"


@stage("law", "lebedev", LebedevLawParams)
class LebedevLaw:
    """M_i = I_i k_i (w_hat_i - Omega delta_i3) (Lebedev 1976, eq. 4.1 and 4.7).

    Uses the estimator's `omega`; no torque while its `closed_loop` flag is 0 (the start-up
    phase of section 3). An estimator without the flag is taken as always closed.
    """

    @classmethod
    def design(cls, params: LebedevLawParams) -> dict:
        return {"spin_rate": params.omega_ref, "spin_rate_field": f"pipeline.law.{params.rate_key}"}

    def __init__(self, params: LebedevLawParams, ctx):
        require_free_body(ctx, "law", "lebedev")
        self.inertia = principal_axes_moments(ctx.inertia)
        self.target = np.array([0.0, 0.0, params.omega_ref])
        with scenario_fields({"control.gains": "pipeline.law.gains_per_s", "body.inertia": "model.inertia_kg_m2"}):
            self.k = check_gains(self.inertia, params.omega_ref, params.gains_per_s)

    @classmethod
    def batched(cls, stages: list) -> LebedevTorques:
        """The laws of a batch's worlds on (N, ...) arrays (testbed.lebedev.batched)."""
        return LebedevTorques(stages)

    def torque(self, t, estimate):
        closed = bool(np.asarray(estimate.get("closed_loop", [1.0]))[0])
        if not closed or "omega" not in estimate:
            return {"torque": np.zeros(3)}
        z = np.asarray(estimate["omega"], float) - self.target
        return {"torque": lebedev_torque(self.inertia, self.k, z)}


# --- the observer (eq. 3.1 and 4.6) --------------------------------------------------------

@dataclass(kw_only=True)
class LebedevObserverParams:
    poles_per_s: list[float] = param(length=3, doc="real parts of the wanted eig(A - l C); repeats allowed")
    poles_imag_per_s: list[float] = param([0.0, 0.0, 0.0], length=3, doc="imaginary parts (conjugate pairs)")
    startup_s: float = param(ge=0, doc="open-loop start-up phase (section 3) before control begins")
    max_substep_s: float = param(0.05, ge=1e-4, doc="RK4 substep of the observer ODE within a control period")
    measurement_hold: Literal["zero_order", "linear"] = param("zero_order", doc=(
        "y between two samples: the older held (zero_order) or interpolated linearly to the newer "
        "(linear; causal, both samples are in hand when the interval is integrated)"))
    design_momentum_nms: list[float] | None = param(None, length=3, doc=(
        "internal (CMG) momentum H at the operating point, body axes: the closed-loop gain then places "
        "eig(A + I^-1 [H x] - l C); none: the paper's rigid body"))
    momentum_gain: Literal["fixed", "measured"] = param("fixed", doc=(
        "measured: the gains follow the momentum H the allocator reports (re-placed every period, "
        "the start-up model includes H; docs/theory/lebedev.md 'Non-zero total momentum'); fixed: design_momentum_nms or none"))

    def validate(self, path: str) -> None:
        with scenario_fields({"observer.poles": join(path, "poles_per_s")}):
            self.poles = check_observer_poles(np.array(self.poles_per_s) + 1j * np.array(self.poles_imag_per_s))
        if self.momentum_gain == "measured" and self.design_momentum_nms is not None:
            raise InputError(join(path, "design_momentum_nms"), "does not apply with momentum_gain measured "
                                                                "(the gain follows the measured H)")


@stage("estimator", "lebedev", LebedevObserverParams)
class LebedevEstimator:
    """One-gyro observer; outputs `z`, its rate estimate `omega_estimate` = z + (0, 0, Omega),
    `closed_loop` (0/1), `innovation` and, once the loop is closed, `omega` (the same estimate). Withholding `omega` during start-up keeps a steering
    allocator from compensating w x H with the start-up transient (peaks of ~70 deg/s)."""

    def __init__(self, params: LebedevObserverParams, ctx):
        require_free_body(ctx, "estimator", "lebedev")
        sensor, law, allocator = ctx.stages["sensor"], ctx.stages["law"], ctx.stages["allocator"]
        if "sensing_axis" not in sensor.design:
            raise InputError("pipeline.sensor.type", f"the lebedev estimator needs the single-axis rate_gyro "
                                                     f"(y = p . w, eq. 1.1), got {sensor.type!r}")
        if "spin_rate" not in law.design:
            raise InputError("pipeline.law.type", f"the lebedev estimator takes Omega from the lebedev law, "
                                                  f"got {law.type!r}")
        if "delivered_torque" not in allocator.design:
            raise InputError("pipeline.allocator.type", f"the lebedev estimator needs u = M / I: use ideal_torque "
                             f"or a steering law that reports torque_delivered, got {allocator.type!r}")
        self.torque_key = allocator.design["delivered_torque"]
        self.momentum_key = allocator.design.get("internal_momentum") if params.momentum_gain == "measured" else None
        # the momentum the cluster holds in full (gimbal-rate terms included) when the allocator
        # reports it: the level of H in the model; `momentum_key`'s H is what the command used
        self.held_key = allocator.design.get("held_momentum", self.momentum_key) if self.momentum_key else None
        self.inertia = principal_axes_moments(ctx.inertia)
        names = {"sensor.axis": "pipeline.sensor.axis", "body.inertia": "model.inertia_kg_m2",
                 "control.spin_rate": law.design["spin_rate_field"],
                 "observer.poles": "pipeline.estimator.poles_per_s",
                 "observer.max_substep": "pipeline.estimator.max_substep_s"}
        with scenario_fields(names):
            self.observer = self.build_observer(params, ctx.inertia, law.design["spin_rate"],
                                                sensor.design["sensing_axis"])
        period = ctx.sample_period or ctx.control_period   # the interval each estimate integrates
        check_rk4_stable(params.poles, period / self.observer.substeps(period), "pipeline.estimator.poles_per_s")
        if self.momentum_key is not None:
            self._check_momentum(ctx, params.startup_s)   # and starts the observer with the H held
        self.startup = params.startup_s
        self.linear_hold = params.measurement_hold == "linear"
        self.l = self.observer.l
        self._t_prev: float | None = None
        self._y_prev = 0.0
        self._command: tuple | None = None   # the cluster's held command (measured momentum)
        self._modelled: np.ndarray | None = None  # the H the model reached at the last sample
        # the fixed-gain closed-loop observer's divergence test (testbed.lebedev.validity); the
        # measured-momentum filter's convergence rests on its information, not on fixed poles
        self.growth = None if self.momentum_key is not None else ErrorGrowth(
            self.observer.inertia, self.observer.spin_rate,
            np.zeros(3) if params.design_momentum_nms is None else params.design_momentum_nms,
            self.observer.l_closed, self.observer.C)

    @classmethod
    def batched(cls, stages: list) -> LebedevEstimates | None:
        """The fixed-gain observers of a batch's worlds on (N, ...) arrays (testbed.lebedev.batched);
        None (per world) for measured momentum (`LebedevEstimates.of`)."""
        return LebedevEstimates.of(stages)

    def _check_momentum(self, ctx, startup: float) -> None:
        """Refuse, before the run, momentum one gyro cannot work with: an idle cluster whose H(0)
        leaves the body at rest unobservable (the filter's start information singular), a
        total momentum L whose end states the filter would hold too little information about
        (testbed.lebedev.momentum), and, when the plant's description offers
        `momentum_gauge`, an L whose end spin the actuators cannot hold or, at the allocator's
        published gimbal-rate limit, turn (testbed.lebedev.end_momentum)."""
        held = np.asarray(ctx.internal_momentum, float)
        obs = self.observer
        obs.start(held)
        least, largest = np.linalg.eigvalsh(obs.info)[[0, -1]]
        if not least > START_RCOND * largest:
            raise InputError("model", f"the momentum the actuators hold at t = 0, H = "
                                      f"{np.array2string(held, precision=4)} N m s: one gyro cannot observe the idle "
                                      f"body at rest (I^-1 [H x], C unobservable: information {least:.3g} of "
                                      f"{largest:.3g})")
        if startup >= ctx.end_time:   # the loop never closes in this run: no end spin to check
            return
        total = np.asarray(ctx.inertia, float) @ np.asarray(ctx.initial.omega, float) + held
        polar = idle_polar_angles(obs.inertia, held, ctx.initial.omega, startup)
        check_momentum_observable(obs.inertia, obs.spin_rate, obs.C, total, obs.decay, "initial",
                                  (float(polar.min()), float(polar.max())))
        if hasattr(ctx.description, "momentum_gauge"):
            rate_limit = ctx.stages["allocator"].design.get("gimbal_rate_limit")
            check_end_momentum_held(ctx.description.momentum_gauge, obs.inertia, obs.spin_rate, total,
                                    float(polar[-1]), "initial", rate_limit)

    @staticmethod
    def build_observer(params: LebedevObserverParams, inertia, spin_rate: float, sensing_axis) -> LebedevObserver:
        """The observer of eq. 3.1 and 4.6 these parameters describe (also built by the
        continuous-time reference, testbed/lebedev/reference.py)."""
        return LebedevObserver(principal_axes_moments(inertia), spin_rate, sensing_axis, params.poles,
                               params.max_substep_s, params.design_momentum_nms,
                               measured_momentum=params.momentum_gain == "measured")

    def _held_command(self, momentum, held, torque):
        """(H at the interval's start, H', w_k x H_k) of the command the cluster holds (measured
        momentum): issued at the last control instant t_k from the momentum H_k it reports
        (`momentum`, what the steering compensated) and the estimate w_k this stage gave then, it
        keeps H' = -(M + w_k x H_k) until the next one (testbed.steering.stage), so the cluster
        holds H(t) = H_held,k + (t - t_k) H', H_held,k the full momentum measured at t_k (`held`).
        A command is new when its H_k or M differs from the one held (at the sensor's faster
        rate the same command comes again)."""
        last = self._command
        if last is None or not (np.array_equal(momentum, last[0]) and np.array_equal(torque, last[1])):
            compensated = cross3(self.observer.omega_estimate(), momentum)   # w_k: this stage's output at t_k
            last = self._command = (momentum, torque, held, -(torque + compensated), compensated, self._t_prev)
        _, _, held, rate, compensated, issued = last
        return held + (self._t_prev - issued) * rate, rate, compensated

    def _step_measured(self, y_end, h, command) -> None:
        """One interval of the measured-momentum observer (docs/theory/lebedev.md "Non-zero total momentum"). The
        model runs in w, but it stands for the total momentum in body axes L_b = I w_hat + H,
        whose motion L_b' = L_b x w holds whatever the cluster does: when the interval starts
        from a measured H that differs from the H the model reached, the estimate keeps L_b and
        moves w_hat by -I^-1 dH (LebedevObserver.hold_total_momentum), so a momentum exchange
        the held command does not contain (servo lag, the curvature of H(beta) over the period,
        a vertex switch, the gimbals' own momentum) enters w_hat algebraically, as the truth's
        w = I^-1 (L_b - H), instead of integrating as a torque error. Causal: the H used was
        measured at the previous sample (the allocator's output of the last tick)."""
        held = np.asarray(command.get(self.held_key, command[self.momentum_key]), float)
        if self._t_prev < self.startup:
            start, rate = held, np.zeros(3)
        else:
            momentum = np.asarray(command.get(self.momentum_key), float)
            torque = np.asarray(command.get(self.torque_key, np.zeros(3)), float)
            start, rate, compensated = self._held_command(momentum, held, torque)
        if self._modelled is not None:
            self.observer.hold_total_momentum(self._modelled, start)
        if self._t_prev < self.startup:
            self.observer.startup_step(self._y_prev, h, y_end, start)                # the idle body
        else:
            self.observer.step(self._y_prev, torque / self.inertia, h, y_end, start, rate, compensated)
        self._modelled = start + h * rate

    def _step(self, y: float, h: float, command) -> None:
        """Integrate the observer over the interval of length h [s] that ends at the sample y."""
        y_end = y if self.linear_hold else None
        if self.momentum_key is not None and self.momentum_key in command:
            self._step_measured(y_end, h, command)
        elif self._t_prev < self.startup:
            self.observer.startup_step(self._y_prev, h, y_end)                # eq. 3.1, body uncontrolled
        else:
            torque = np.asarray(command.get(self.torque_key, np.zeros(3)), float)
            self.observer.step(self._y_prev, torque / self.inertia, h, y_end)  # eq. 4.6, u = M / I

    @contextlib.contextmanager
    def _diverging(self):
        """An overflow while integrating the observer or testing it is its divergence, said so with
        the size of the estimate it started from (the run's floating-point errors raise: testbed.runner)."""
        before = self.observer.z.copy()
        try:
            yield
        except FloatingPointError as exc:
            with np.errstate(all="ignore"):   # its size may overflow a float's square too
                size = np.degrees(np.linalg.norm(before))
            raise MethodFailed(f"the observer diverged: its state overflowed ({exc}) integrating from "
                               f"|w_hat - Omega e_z| = {size:.3g} deg/s") from exc

    def estimate(self, t, measurement, command):
        y = float(np.asarray(measurement["y"])[0])
        if self._t_prev is not None:
            h = t - self._t_prev
            with self._diverging():
                self._step(y, h, command)
                if self.growth is not None and self._t_prev >= self.startup:
                    self.growth.advance(t, h, self.observer.omega_estimate())
        self._t_prev, self._y_prev = t, y
        obs = self.observer
        innovation = output_error(obs.C.tolist(), obs.z.tolist(), y - obs.C[2] * obs.spin_rate)
        closed = t >= self.startup
        omega = obs.omega_estimate()
        out = {"z": obs.z.copy(), "omega_estimate": omega,
               "closed_loop": np.array([1.0 if closed else 0.0]), "innovation": np.array([innovation])}
        if closed:  # the start-up estimate may be far off: nobody downstream acts on it
            out["omega"] = omega.copy()
        return out

