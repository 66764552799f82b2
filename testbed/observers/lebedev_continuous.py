"""The continuous-time closed loop of Lebedev (1976), solved to high accuracy with SciPy.

The body, the observer and the law with nothing sampled, the system the paper's section-6
example and Fig. 1 describe. State (w, z, H): body rate [rad/s], observer state z (the
estimate of x = w - (0, 0, Omega), eq. 4.1) and the momentum H an internal actuator holds
(body axes [N m s]; zero and constant for ideal body torques).

- start-up, 0 <= t < t*: the body is uncontrolled, I w' = -w x (I w + H), H constant; the
  linear observer z' = A z + l (y - C z) (eq. 3.1, or its form with H, `startup_model`) runs
  from z = 0;
- closed loop, t >= t*: the law M = I K z (eq. 4.7); the observer
  z' = A z + l_c (y - C z) + F(z) + u with u = M / I (eq. 4.6); ideal torques act on the
  body directly, I w' = M - w x I w; an internal actuator that compensates w x H with the
  estimate delivers H' = -(M + w_hat x H) (SEEDS §004 eq. 14), so the bus feels
  I w' = M - w x I w + (w_hat - w) x H (README "One gyro, no attitude sensor").

y = p . w + b is the ideal gyro (plus a constant bias b), taken continuously. The observer's
gains may follow the momentum held (`momentum_gain: measured`): its `startup_model(H)` and
`closed_gain(H, z)` are called with the H and z of the state.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

from testbed.errors import InputError
from testbed.observers.lebedev_observer import lebedev_nonlinearity


def _cross(a, b):
    """a x b of two 3-vectors (np.cross costs several times more on vectors this small)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


# Right-hand-side evaluations allowed for one solution (the paper's 1000 s take 16 000): a stiff
# design (very fast poles, a huge gain) would otherwise keep DOP853 busy for hours.
MAX_EVALUATIONS = 100_000
RTOL = 1e-11          # DOP853's relative tolerance (the accuracy the issue's figures were measured at)
ATOL_RAD_S = 1e-15    # absolute tolerance on rates; momenta are scaled by I Omega (below)


def closed_loop_states(observer, gains, startup_s: float, omega0, momentum0, times, *, internal: bool,
                       bias: float = 0.0) -> np.ndarray:
    """The continuous closed loop's state at `times` (N,) -> (N, 9): columns w [rad/s], z
    [rad/s] and H [N m s], body axes.

    `observer`: the LebedevObserver whose design is solved (inertia, Omega, C; the start-up
    model `startup_model(H)` and the gain `closed_gain(H, z)` for the momentum H held); `gains`
    k of eq. 4.7 [1/s]; `internal`: torques come from an internal actuator holding H (else
    ideal external torques, H = 0). Solved with DOP853 in two legs split at t*.
    """
    inertia = observer.inertia
    spin_rate, C, a, A = observer.spin_rate, observer.C, observer.a, observer.A
    k = np.asarray(gains, float)
    target = np.array([0.0, 0.0, spin_rate])
    y_offset = C[2] * spin_rate - bias            # y - C x - b = gamma Omega (eq. 4.3)
    scale = np.concatenate([np.full(6, 1.0), np.full(3, np.max(inertia) * max(abs(spin_rate), 1e-300))])
    held = np.asarray(momentum0, float) if internal else None
    startup_matrix, drift, startup_gain = observer.startup_model(held)   # the idle actuators hold H(0)

    def open_loop(_, s):
        w, z, h = s[:3], s[3:6], s[6:]
        dw = -_cross(w, inertia * w + h) / inertia
        dz = startup_matrix @ z + drift + startup_gain * (C @ w - y_offset - C @ z)
        return np.concatenate([dw, dz, np.zeros(3)])

    def closed_loop(t, s):
        w, z, h = s[:3], s[3:6], s[6:]
        u = k * z                                  # M / I, eq. 4.7
        torque = inertia * u
        if internal:
            w_hat = z + target
            dh = -(torque + _cross(w_hat, h))
            dw = (torque - _cross(w, inertia * w) + _cross(w_hat - w, h)) / inertia
            try:
                gain = observer.closed_gain(h, z)
            except InputError as exc:   # the operating point crossed an unobservable state
                raise ArithmeticError(f"the continuous loop loses observability at t = {t:.6g} s: "
                                      f"{exc.reason}") from None
        else:
            dh = np.zeros(3)
            dw = (torque - _cross(w, inertia * w)) / inertia
            gain = observer.closed_gain()
        dz = A @ z + gain * (C @ w - y_offset - C @ z) + lebedev_nonlinearity(a, z) + u
        return np.concatenate([dw, dz, dh])

    evaluations = [0]

    def counted(rhs):
        def f(t, s):
            evaluations[0] += 1
            if evaluations[0] > MAX_EVALUATIONS:
                raise ArithmeticError(f"the continuous loop needs more than {MAX_EVALUATIONS} evaluations "
                                      f"(stiff at t = {t:.6g} s)")
            return rhs(t, s)
        return f

    times = np.asarray(times, float)
    state = np.concatenate([np.asarray(omega0, float), np.zeros(3),
                            np.asarray(momentum0, float) if internal else np.zeros(3)])
    out = np.empty((times.size, 9))
    t_end = float(times[-1])
    legs = ((0.0, min(startup_s, t_end), open_loop, times < startup_s),
            (min(startup_s, t_end), t_end, closed_loop, times >= startup_s))
    for t0, t1, rhs, mask in legs:
        if t1 > t0:
            sol = solve_ivp(counted(rhs), (t0, t1), state, method="DOP853", rtol=RTOL, atol=ATOL_RAD_S * scale,
                            dense_output=True)
            if not sol.success:
                raise ArithmeticError(f"the continuous closed loop could not be solved: {sol.message}")
            state = sol.y[:, -1]
            if mask.any():
                out[mask] = sol.sol(times[mask]).T
        elif mask.any():
            out[mask] = state
    return out
