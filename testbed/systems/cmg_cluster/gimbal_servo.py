"""The gimbal-rate servos of the CMG spacecraft (`model.servo_model`), applied once per control tick.

intvelocity  MuJoCo's integrated-velocity actuator alone (model.py `servo_gains`): the
    activation integrates the command, act' = c, and the torque is kp (act - b) - kv b'.
    Stiffness alone holds the gimbal against its gyroscopic torque (the spinning rotor on a
    turning bus, up to 4.2 N m in cmg_open_loop), deflecting it by torque / (J w_n^2):
    0.03 deg at w_n = 316 rad/s, 0.6 deg at 69 rad/s. It tracks well only when stiff, and
    RK4 then needs w_n dt <= 0.7 (dt <= 2 ms at 316 rad/s).

feedforward  the same PD loop, softer (w_n of a few rad/s), plus one motor per gimbal
    (`gimbal_torque<i>`) whose torque u_k is held over control tick k like the command. Per
    gimbal, with theta = b - act and e = b' - c_k, the tick's dynamics are

        J e' = -kp theta - kv e + (u_k - kv c_k + delta),   theta' = e,

    delta being every torque on the gimbal axis but the servo's (gyroscopic and coupling
    torques). For a constant acceleration a = (u_k - kv c_k + delta) / J over the tick,
    (theta, e)(t_k + Tc) = Phi (theta_k, e_k) + Gamma a with Phi = exp(A Tc),
    A = [[0, 1], [-w_n^2, -2 zeta w_n]] and Gamma = int_0^Tc exp(A s) ds (0, 1)
    (`rate_deadbeat_gains`). The motor torque that ends the tick at the commanded rate,
    e(t_k + Tc) = 0, is

        u_k = kv c_k - J (p theta_k + q e_k) - delta_k^,   p = Phi_10 / Gamma_1, q = Phi_11 / Gamma_1,

    and the rate error r = b'(t_k+1) - c_k that remains tells the disturbance the tick met,
    averaged with the PD's weights: delta_k = delta_k^ + J r / Gamma_1 (a disturbance
    observer on the gimbal's own tachometer). The next tick uses the linear extrapolation
    delta_k+1^ = 2 delta_k - delta_k-1 + D (second difference of the PD-weighted mean gimbal
    angles over the ticks k-1, k and k+1, the coming one predicted with the rate ramping to the
    command): the gyroscopic torque h_i w . J_i changes with the angles as the bus turns under the
    cluster and J_i turns with its gimbal (D, `angle_sensitivity_times`), so when the rates jump its
    slope jumps with them, which a linear extrapolation alone misses by a few % of the jump on
    the next tick. What is left is the curvature of the rest (second order in Tc).
    Before t = 0 the servo held the gimbal at
    rest: delta^ starts at the torque MuJoCo computes on the gimbal at the initial state
    (-qfrc_bias). J is the gimbal's effective inertia 1 / (M^-1)_gg (the bus and the other
    gimbals recoil a little), read from MuJoCo's mass matrix at t = 0. With a torque limit
    the motor torque is clipped to it and the observer reads the next residual against the
    torque given (no wind-up); MuJoCo clamps the PD and motor torques together, so the
    observer is exact again a few ticks after the limit lets go. The feedforward servo
    tracks the held command to about 2e-5 of its amplitude at dt = Tc = 0.01 s, where the
    intvelocity servo at the most RK4 accepts (w_n = 69 rad/s) is off by 2.3 %.

Where the momentum drift at large steps comes from. Every servo and motor torque acts
between a gimbal and the bus, so the equations conserve the total angular momentum exactly;
what drifts in a run is RK4's truncation error. Measured on cmg_open_loop (600 s,
dt = Tc = 0.01 s unless said; drift = max |L(t) - L(0)| / 200 N m s, the stored rotor
momentum; `bench/bench_frontier.py --sources` prints every number below):
- the start. At t = 0 the gimbals are at rest and the command is not (up to 3 deg/s). The
  intvelocity servo also meets the gyroscopic torque unbalanced, rings at w_n, and RK4's
  error per step on that transient is about (w_n dt)^5 / 120 of it: at w_n = 69 rad/s the
  drift is 3.17e-10 by t = 0.1 s and 3.18e-10 after 600 s (dt 0.005 s: 1.4e-11, the dt^4
  of RK4). The feedforward servo holds the gyroscopic torque from t = 0 (a zero command's
  first step keeps L to 1e-15) but brings the gimbals to c(0) within the first tick: an
  acceleration of c(0) / Tc, which the PD's damping resists, so this one step costs more
  the stiffer the PD: 3.1e-11 at w_n = 1 rad/s, 1.6e-10 at 5, 1.2e-9 at 30, and 2e-14 when
  the command starts at zero.
- not the rotors: at 12 000 rpm with the same gimbal-axis inertia, the rotors turning two
  revolutions a step, the drift is the same to three digits as at 6000 rpm (3.18e-10
  intvelocity; 1.42e-10 and 1.43e-10 feedforward); a rotor loop time constant of 0.2 s
  instead of 0.02 s changes nothing either.
- the gimbals turning on the turning bus: after the start, the drift grows while the gimbals
  move (1.43e-10 over 600 s with the command starting at zero; 7.6e-13 with the gimbals
  still), with the square of their rates (amplitude x2: 6.8e-10), inversely with the
  gimbal-axis inertia (4.5 times more: 2.9e-11) and as dt^4 (dt 0.005 s: 6.7e-12): RK4's
  error in the gyroscopic coupling of gimbals and bus.
At dt = Tc = 0.01 s the feedforward servo with w_n = 5 rad/s thus drifts 2.4e-10 and tracks
to 2.4e-5 of the amplitude (docs/theory/gimbal-servo.md, "The gimbal servo and the time step").
"""

from __future__ import annotations

import mujoco
import numpy as np
from scipy.linalg import expm

from testbed.errors import InputError
from testbed.plant import float_writer

# The observer divides the residual rate by Gamma_1, which shrinks as exp(-w_n Tc): past
# w_n Tc = 5 the PD alone settles within the tick and the division only amplifies round-off.
MAX_FEEDFORWARD_OMEGA_TC = 5.0


def rate_deadbeat_gains(natural_frequency: float, damping_ratio: float, control_period: float):
    """(p, q, Gamma_1) of the module docstring: over one control period of the PD loop
    J e' = -kp theta - kv e + J a (w_n, zeta), e(Tc) = Phi_10 theta_0 + Phi_11 e_0 + Gamma_1 a.
    Phi and Gamma come from one matrix exponential of the augmented system (Van Loan)."""
    w_n, zeta, tc = natural_frequency, damping_ratio, control_period
    augmented = np.zeros((3, 3))
    augmented[:2, :2] = [[0.0, 1.0], [-w_n * w_n, -2.0 * zeta * w_n]]
    augmented[1, 2] = 1.0  # the constant acceleration a enters e'
    transition = expm(augmented * tc)
    gamma = transition[1, 2]
    return transition[1, 0] / gamma, transition[1, 1] / gamma, gamma


def kernel_moments(natural_frequency: float, damping_ratio: float, control_period: float):
    """(m1, m2): the first two moments of the PD's weighting of an acceleration over a tick,
    m_k = int_0^Tc G(Tc - s) s^k ds / Gamma_1 with G(tau) = [exp(A tau)]_11, so that an input
    a(s) = a0 + a1 s + a2 s^2 ends the tick as the constant a0 + a1 m1 + a2 m2 would
    (the polynomial input appended to the augmented system, Van Loan)."""
    w_n, zeta, tc = natural_frequency, damping_ratio, control_period
    moments = []
    for power in (0, 1, 2):
        augmented = np.zeros((5, 5))  # (theta, e, 1, s, s^2): the last three generate s^k
        augmented[:2, :2] = [[0.0, 1.0], [-w_n * w_n, -2.0 * zeta * w_n]]
        augmented[1, 2 + power] = 1.0
        augmented[3, 2], augmented[4, 3] = 1.0, 2.0
        moments.append(expm(augmented * tc)[1, 2])
    return moments[1] / moments[0], moments[2] / moments[0]


class IntVelocityServo:
    """Hands the gimbal-rate command to MuJoCo's intvelocity actuators and remembers the
    command held over the last control period (what the servo was asked to track)."""

    def __init__(self, bus, data, rate_limit: float | None = None):
        self._rates = data.ctrl[bus.gimbal_ctrl]  # views into MuJoCo's arrays, kept
        self._write = float_writer(self._rates)  # what apply writes
        self.rate_limit = rate_limit
        self._applied_at = None
        self._jammed: list[int] = []  # gimbals held at rest whatever the command (a stuck fault)
        IntVelocityServo.start(self, data)  # not a subclass's: that one needs mj_forward first

    def start(self, data) -> None:
        """At the initial state: the command held before t = 0 is the one in MuJoCo's ctrl."""
        self._current = self._previous = self._rates.tolist()

    def apply(self, data, rates) -> None:
        """Take this tick's command (None: hold the last one)."""
        if self._take(data, rates):
            self._write(*self._current)  # MuJoCo clips to the rate limit (ctrlrange)

    def _take(self, data, rates) -> bool:
        """Remember this tick's command and the one held until now; False: no new command."""
        self._previous = self._current
        self._applied_at = data.time
        if rates is None:
            return False
        if type(rates) is list:  # a built-in allocator's plain floats
            self._current = rates.copy()
        else:
            self._current = rates.tolist() if type(rates) is np.ndarray else [float(r) for r in rates]
        for i in self._jammed:
            self._current[i] = 0.0
        return True

    def jam(self, i: int) -> None:
        """Gimbal i holds its angle from now on, whatever it is commanded (a stuck fault, faults.py)."""
        self._jammed.append(i)

    def held_command(self, data) -> np.ndarray:
        """The gimbal-rate command [rad/s] the servos held over the control period that ends
        now (before the rate limit): the previous tick's when a command was applied at this
        time, else the last one."""
        held = self._previous if self._applied_at == data.time else self._current
        return np.array(held, dtype=float)

    def limit_rate(self, i: int, limit: float) -> None:
        """Gimbal i follows commands up to `limit` [rad/s] from now on (a rate_limit fault,
        faults.py); the servo's own limit, when lower, stays."""
        limits = [np.inf] * len(self._rates) if self.rate_limit is None else (
            [self.rate_limit] * len(self._rates) if np.isscalar(self.rate_limit) else list(self.rate_limit))
        limits[i] = min(limits[i], limit)
        self.rate_limit = limits

    def _clipped(self, rates: list) -> list:
        limit = self.rate_limit
        if limit is None:
            return rates
        if np.isscalar(limit):
            return [min(max(r, -limit), limit) for r in rates]
        return [min(max(r, -bound), bound) for r, bound in zip(rates, limit)]


class FeedForwardServo(IntVelocityServo):
    """The feedforward servo of the module docstring: the intvelocity PD plus a motor torque
    per gimbal, held over each control tick, and a disturbance observer."""

    def __init__(self, bus, model, data, natural_frequency: float, damping_ratio: float,
                 control_period: float, rate_limit: float | None = None, torque_limit: float | None = None):
        if natural_frequency * control_period > MAX_FEEDFORWARD_OMEGA_TC:
            raise InputError("model.servo_natural_frequency_rad_s",
                             f"w_n Tc = {natural_frequency * control_period:.3g} exceeds "
                             f"{MAX_FEEDFORWARD_OMEGA_TC:g}: the PD alone settles within the control "
                             "period, use servo_model: intvelocity")
        super().__init__(bus, data, rate_limit)
        # the servos' rate commands and the motors' torques, side by side in MuJoCo's ctrl
        self._write = float_writer(data.ctrl[bus.gimbal_servo_ctrl])
        self._rate = data.qvel[bus.gimbal_qvel]
        self._angle = data.qpos[bus.gimbal_qpos]
        self._setpoint = data.act[bus.gimbal_act]
        self._bias = data.qfrc_bias[bus.gimbal_qvel]
        self._dofs = np.asarray(bus.gimbal_qvel_adr)
        self._kv = -model.actuator_biasprm[bus.gimbal_actuator_ids, 2]
        self.p, self.q, self.gamma = rate_deadbeat_gains(natural_frequency, damping_ratio, control_period)
        self.m1, self.m2 = (float(m) for m in kernel_moments(natural_frequency, damping_ratio, control_period))
        self.period = control_period
        self.torque_limit = torque_limit
        self.model = model
        self.geometry = bus.geometry
        self._bus_rate = data.qvel[bus.qvel_adr + 3:bus.qvel_adr + 6]  # body frame
        self._rotor_rate = data.qvel[bus.rotor_qvel]
        self._bus_dofs = np.arange(bus.qvel_adr, bus.qvel_adr + 6)

    def start(self, data) -> None:
        """At the initial state, after mj_forward: effective inertias from the mass matrix,
        the observer at the torque that held the gimbals at rest."""
        inverse = np.zeros((self.model.nv, self.model.nv))
        mujoco.mj_solveM(self.model, data, inverse, np.eye(self.model.nv))
        inertia = 1.0 / np.diag(inverse)[self._dofs]
        # per gimbal, so that u = kv c - J (p theta + q (b' - c)) - delta^
        #                       = (kv + J q) c - J p theta - J q b' - delta^
        # (i, J / Gamma_1, kv + J q, J p, J q) a gimbal: one tuple unpacked costs less than four subscripts
        self._gains = list(zip(range(len(inertia)), (inertia / self.gamma).tolist(),
                               (self._kv + inertia * self.q).tolist(), (inertia * self.p).tolist(),
                               (inertia * self.q).tolist()))
        # the observer: delta over the last tick, and delta^ over the coming one (two lists,
        # updated in place every tick, as is the torque)
        self._delta = (-self._bias).tolist()
        self._predicted = list(self._delta)
        self._torque = [0.0] * len(self._delta)
        self._current = self._previous = self._rate.tolist()  # no rate error before t = 0
        # the bus's rotational response to a torque from the cluster, the gimbals moving as
        # commanded: the rotational block of the inverse of the bus's 6x6 block of M
        full = np.zeros((self.model.nv, self.model.nv))
        mujoco.mj_fullM(self.model, data, full)
        self._bus_response = np.linalg.inv(full[np.ix_(self._bus_dofs, self._bus_dofs)])[3:, 3:].tolist()
        # the gimbals' angles and rates at the last tick and their weighted mean angles over
        # the last two ticks (at rest before t = 0)
        self._last_angle, self._last_rate = self._angle.tolist(), self._rate.tolist()
        self._mean_before = self._angle.tolist()

    def angle_sensitivity_times(self, x: list) -> list:
        """D x for D = d(delta')/d(beta') [N m s / rad], (4, 4), at the present state, and x a
        list of four gimbal angles [rad]; D x [N m] as plain floats. The disturbance on gimbal i is
        h_i w . J_i (the rotor's gyroscopic torque, J_i the unit torque axis), and it changes as
        the bus turns under the cluster's torque, w' = -R sum_j h_j J_j b'_j (R the bus's
        rotational response), and as J_i turns with the gimbal, dJ_i/db_i = -s_i:
        D_ij = -h_i h_j J_i^T R J_j - [i = j] h_i w . s_i (docs/theory/gimbal-servo.md), so
        (D x)_i = -h_i (J_i . R sum_j h_j x_j J_j + (w . s_i) x_i): D itself is never formed.
        J_i and s_i are the cluster's turned axes, kept for the tick's angles (the steering stage
        asks for the same ones), as floats; all in plain floats (cheaper than numpy for 4 x 3 numbers)."""
        spin, columns = self.geometry.turned_axes_floats(self._angle)
        h = (self.geometry.spin_inertia * self._rotor_rate).tolist()
        w0, w1, w2 = self._bus_rate.tolist()
        t0 = t1 = t2 = 0.0  # sum_j h_j x_j J_j
        for h_j, x_j, (a, b, c) in zip(h, x, columns):
            k = h_j * x_j
            t0, t1, t2 = t0 + k * a, t1 + k * b, t2 + k * c
        (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = self._bus_response
        u0, u1, u2 = r00 * t0 + r01 * t1 + r02 * t2, r10 * t0 + r11 * t1 + r12 * t2, r20 * t0 + r21 * t1 + r22 * t2
        return [-h_i * (a * u0 + b * u1 + c * u2 + (sa * w0 + sb * w1 + sc * w2) * x_i)
                for h_i, x_i, (a, b, c), (sa, sb, sc) in zip(h, x, columns, spin)]

    def _angle_correction(self, command: list, angle: list, rate: list) -> list:
        """D times the second difference of the PD-weighted mean gimbal angle over the last two
        ticks and the coming one (predicted with the rate ramping from the measured one to the
        command): the part of the disturbance's change that a linear extrapolation misses when
        the rates change (module docstring). `angle`, `rate`: the gimbals' now, plain floats."""
        m1, ramp = self.m1, self.m2 / (2.0 * self.period)
        mean_last = [a + r * m1 + (r_now - r) * ramp
                     for a, r, r_now in zip(self._last_angle, self._last_rate, rate)]
        mean_next = [a + r * m1 + (c - r) * ramp for a, r, c in zip(angle, rate, command)]
        second = [n - 2.0 * last + before for n, last, before in zip(mean_next, mean_last, self._mean_before)]
        self._mean_before, self._last_angle, self._last_rate = mean_last, angle, rate
        return self.angle_sensitivity_times(second)

    def apply(self, data, rates) -> None:
        """This tick's command: the observer's update from the last tick, then the held
        motor torque u_k (module docstring). Plain floats: four gimbals cost less in Python
        arithmetic than in numpy's calls."""
        self._take(data, rates)
        if self.rate_limit is None:
            command, followed = self._current, self._previous
        else:
            command, followed = self._clipped(self._current), self._clipped(self._previous)
        rate, angle, setpoint = self._rate.tolist(), self._angle.tolist(), self._setpoint.tolist()
        delta, coming, torque = self._delta, self._predicted, self._torque  # last tick's, overwritten here
        correction = self._angle_correction(command, angle, rate)
        for i, gain, kv_q, jp, jq in self._gains:  # in place: cheaper than zips, comprehensions or new lists
            rate_i = rate[i]
            delta_i = coming[i] + gain * (rate_i - followed[i])  # the disturbance the last tick met
            # extrapolated over this tick, plus what the gimbals' changed rates change in it
            coming_i = coming[i] = 2.0 * delta_i - delta[i] + correction[i]
            delta[i] = delta_i
            torque[i] = kv_q * command[i] - jp * (angle[i] - setpoint[i]) - jq * rate_i - coming_i
        limit = self.torque_limit
        if limit is not None:
            for i in range(len(torque)):
                applied = min(max(torque[i], -limit), limit)
                # what the motor leaves out counts as disturbance it did not compensate, so the
                # next tick's residual is read against the torque it really gave
                coming[i] = coming[i] + torque[i] - applied
                torque[i] = applied
        self._write(*self._current, *torque)  # MuJoCo clips the rates to the limit (ctrlrange)
