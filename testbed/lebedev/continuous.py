"""The continuous-time closed loop of Lebedev (1976), solved to high accuracy with SciPy.

The body, the observer and the law with nothing sampled, the system the paper's section-6
example and Fig. 1 describe. State (w, z, H): body rate [rad/s], observer state z (the
estimate of x = w - (0, 0, Omega), eq. 4.1) and the momentum H an internal actuator holds
(body axes [N m s]; zero and constant for ideal body torques).

- start-up, 0 <= t < t*: the body is uncontrolled, I w' = -w x (I w + H), H constant; the
  linear observer z' = A z + l (y - C z) (eq. 3.1, or with H the observer's
  `startup_derivative`) runs from z = 0 (with H: from the body at rest, `start`);
- closed loop, t >= t*: the law M = I K z (eq. 4.7); the observer
  z' = A z + l_c (y - C z) + F(z) + u with u = M / I (eq. 4.6); ideal torques act on the
  body directly, I w' = M - w x I w; an internal actuator that compensates w x H with the
  estimate delivers H' = -(M + w_hat x H) (SEEDS §004 eq. 14), so the bus feels
  I w' = M - w x I w + (w_hat - w) x H (docs/theory/lebedev.md "One gyro, no attitude sensor").

y = p . w + b is the ideal gyro (plus a constant bias b), taken continuously. The observer's
model and gain may follow the momentum held (`momentum_gain: measured`): the observer's own
`startup_derivative` and `closed_derivative` are integrated, with the H of the state (and the
observer's information matrix Pi beside z).
"""

from __future__ import annotations

import numpy as np

from testbed.math.cross import cross3

# Right-hand-side evaluations allowed for one solution (the paper's 1000 s take 16 000): a stiff
# design (very fast poles, a huge gain) would otherwise keep DOP853 busy for hours.
MAX_EVALUATIONS = 100_000
RTOL = 1e-11          # DOP853's relative tolerance (the accuracy the issue's figures were measured at)
ATOL_RAD_S = 1e-15    # absolute tolerance on rates; momenta are scaled by I Omega (below)


def closed_loop_states(observer, gains, startup_s: float, omega0, momentum0, times, *, internal: bool,
                       bias: float = 0.0) -> np.ndarray:
    """The continuous closed loop's state at `times` (N,) -> (N, 9): columns w [rad/s], z
    [rad/s] and H [N m s], body axes.

    `observer`: the LebedevObserver whose design is solved (inertia, Omega, C; its
    `startup_derivative` and `closed_derivative` for the momentum H held); `gains`
    k of eq. 4.7 [1/s]; `internal`: torques come from an internal actuator holding H (else
    ideal external torques, H = 0). Solved with DOP853 in two legs split at t*.
    """
    inertia = observer.inertia
    spin_rate, C = observer.spin_rate, observer.C
    k = np.asarray(gains, float)
    target = np.array([0.0, 0.0, spin_rate])
    y_offset = C[2] * spin_rate - bias            # y - C x - b = gamma Omega (eq. 4.3)
    held = np.asarray(momentum0, float) if internal else None
    observer.start(held)
    estimator0 = observer.state(held)             # z(0) (and, with measured momentum, Pi for H(0))
    n = estimator0.size
    scale = np.concatenate([np.full(3 + n, 1.0), np.full(3, np.max(inertia) * max(abs(spin_rate), 1e-300))])
    if n > 3:   # the information matrix Pi: absolute tolerance RTOL of its size at t = 0
        scale[6:3 + n] = RTOL * np.max(np.abs(estimator0[3:])) / ATOL_RAD_S

    def open_loop(_, s):
        w, estimator, h = s[:3], s[3:3 + n], s[3 + n:]
        dw = -cross3(w, inertia * w + h) / inertia
        d_estimator = observer.startup_derivative(estimator, C @ w - y_offset, held)   # H(0) held while idle
        return np.concatenate([dw, d_estimator, np.zeros(3)])

    def closed_loop(t, s):
        w, estimator, h = s[:3], s[3:3 + n], s[3 + n:]
        u = k * estimator[:3]                      # M / I, eq. 4.7
        torque = inertia * u
        if internal:
            w_hat = estimator[:3] + target
            dh = -(torque + cross3(w_hat, h))
            dw = (torque - cross3(w, inertia * w) + cross3(w_hat - w, h)) / inertia
        else:
            dh = np.zeros(3)
            dw = (torque - cross3(w, inertia * w)) / inertia
        try:
            d_estimator = observer.closed_derivative(estimator, C @ w - y_offset, u, h if internal else None)
        except np.linalg.LinAlgError as exc:   # the information matrix lost rank: nothing observed
            raise ArithmeticError(f"the continuous loop loses observability at t = {t:.6g} s: {exc}") from None
        return np.concatenate([dw, d_estimator, dh])

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
    state = np.concatenate([np.asarray(omega0, float), estimator0.copy(),
                            np.asarray(momentum0, float) if internal else np.zeros(3)])
    out = np.empty((times.size, 9))
    t_end = float(times[-1])
    legs = ((0.0, min(startup_s, t_end), open_loop, times < startup_s),
            (min(startup_s, t_end), t_end, closed_loop, times >= startup_s))
    for t0, t1, rhs, mask in legs:
        if t1 > t0:
            from scipy.integrate import solve_ivp  # on use: at the top it would cost every command start-up time
            sol = solve_ivp(counted(rhs), (t0, t1), state, method="DOP853", rtol=RTOL, atol=ATOL_RAD_S * scale,
                            dense_output=True)
            if not sol.success:
                raise ArithmeticError(f"the continuous closed loop could not be solved: {sol.message}")
            state = sol.y[:, -1]
            if mask.any():
                out[mask] = sol.sol(times[mask])[np.r_[0:6, 3 + n:6 + n]].T
        elif mask.any():
            out[mask] = state[np.r_[0:6, 3 + n:6 + n]]
    return out
