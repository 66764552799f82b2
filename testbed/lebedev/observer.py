"""Spin control of a rigid body from ONE single-axis rate gyro (Lebedev 1976).

The body spins about its z axis at Omega; the state is the deviation
x = (wx, wy, wz - Omega) (eq. 4.1) and obeys x' = A x + F(x) + u (eq. 4.2) with
u = M / I. The only measurement is the gyro output y = p . w (eq. 1.1); in deviation
form that is y = C x + gamma * Omega with C = p (eq. 4.3), so every innovation below is
taken on y_dev = y - gamma * Omega. A full-order observer (eq. 4.6) estimates x; the
control law (eq. 4.7) feeds the estimate back, M_i = I_i k_i z_i.

Pure numpy: no MuJoCo here. Units SI, rates in rad/s.
"""

import math

import numpy as np

from testbed.errors import InputError
from testbed.math.validation import check_unit_vector, principal_moments
from testbed.math.cross import cross3
from testbed.math.information_filter import filter_gain, gathered_information, information_rate
from testbed.math.rk4 import rk4_steps

# Tolerance for "this factor vanishes" in the observability test, relative to the size
# of the quantities it is built from (inputs are floats from a scenario file).
_REL_ZERO = 1e-12
# How long (in units of 1/a) the information filter's start pair is taken to have been seen:
# ten forgetting times 1/2a (the steady information when it exists; a shorter start, 1.5,
# gave gains ten times larger in the first seconds and a start-up transient of ~20 deg/s)
INITIAL_HORIZON_RATES = 5.0


def lebedev_matrices(inertia, spin_rate):
    """Coefficients a_i and the linear matrix A of the deviation equations.

    Lebedev 1976, eq. 4.1-4.2: a1 = (Iy - Iz)/Ix, a2 = (Iz - Ix)/Iy, a3 = (Ix - Iy)/Iz,
    A = [[0, a1 Omega, 0], [a2 Omega, 0, 0], [0, 0, 0]].  Returns (a, A), a = (a1, a2, a3).
    """
    ix, iy, iz = principal_moments("body.inertia", inertia)
    a = np.array([(iy - iz) / ix, (iz - ix) / iy, (ix - iy) / iz])
    w = float(spin_rate)
    A = np.array([[0.0, a[0] * w, 0.0], [a[1] * w, 0.0, 0.0], [0.0, 0.0, 0.0]])
    return a, A


def lebedev_nonlinearity(a, x):
    """Quadratic part of the deviation equations, F(x) = (a1 x2 x3, a2 x1 x3, a3 x1 x2).

    Lebedev 1976, eq. 4.2 (the same function of z appears in the observer, eq. 4.6).
    """
    return np.array(quadratic_terms(a, x))


def quadratic_terms(a, x) -> tuple:
    """The three components of F(x) (`lebedev_nonlinearity`); a and x as three components each,
    floats or arrays of one value per world (a batch's rows)."""
    return a[0] * x[1] * x[2], a[1] * x[0] * x[2], a[2] * x[0] * x[1]


def output_error(c, x, y_dev):
    """y_dev - C x, the innovation in deviation form (eq. 4.3), for c and x given as three
    components (floats, or arrays of one value per world); C x summed left to right, so a world's
    row is its single run's to the bit (numpy's dot of two 3-vectors may round otherwise)."""
    return y_dev - (c[0] * x[0] + c[1] * x[1] + c[2] * x[2])


def startup_rates(linear, drift, gain, c, x, y_dev) -> list:
    """The components of z' = A_s z + d + l (y_dev - C z) (eq. 3.1), given `linear` = A_s z and
    the drift d, the gain l, C and z as three components each (floats, or arrays of one value per world)."""
    error = output_error(c, x, y_dev)
    return [lin + d + g * error for lin, d, g in zip(linear, drift, gain)]


def fixed_gain_rates(linear, gain, a, c, x, y_dev, u) -> list:
    """The components of z' = A z + l (y_dev - C z) + F(z) + u (Lebedev 1976, eq. 4.6), summed in
    that order, given `linear` = A z and l, a, C, z, u as three components each (floats, or
    arrays of one value per world: a batch's worlds in one call)."""
    error = output_error(c, x, y_dev)
    terms = zip(linear, gain, quadratic_terms(a, x), u)
    return [lin + g * error + q + input_ for lin, g, q, input_ in terms]


def observability_matrix(A, C):
    """W = [C', A'C', A'^2 C'] (Lebedev 1976, eq. 4.4); columns are the three vectors."""
    c = np.asarray(C, dtype=float)
    return np.column_stack([c, A.T @ c, A.T @ A.T @ c])


def observability_factor(inertia, spin_rate, sensor_axis):
    """The factored determinant a1 a2 Omega^3 gamma (a2 beta^2 - a1 alpha^2).

    Lebedev 1976, eq. 4.5. Expanding det W along its third row (only C' has a z entry)
    gives exactly this product, so det W equals it with constant 1.
    """
    a, _ = lebedev_matrices(inertia, spin_rate)
    alpha, beta, gamma = np.asarray(sensor_axis, dtype=float)
    w = float(spin_rate)
    return a[0] * a[1] * w**3 * gamma * (a[1] * beta**2 - a[0] * alpha**2)


def check_observable(inertia, spin_rate, sensor_axis):
    """Refuse a configuration that one gyro cannot observe (Lebedev 1976, eq. 4.4-4.5).

    Tests each factor of a1 a2 Omega^3 gamma (a2 beta^2 - a1 alpha^2) and raises
    InputError naming the one that vanishes; returns None when all are non-zero.
    """
    inertia = principal_moments("body.inertia", inertia)
    p = check_unit_vector(sensor_axis, "sensor.axis")
    a, _ = lebedev_matrices(inertia, spin_rate)
    alpha, beta, gamma = p
    ix, iy, iz = inertia
    if abs(float(spin_rate)) == 0.0:
        raise InputError("control.spin_rate", "unobservable: spin rate Omega is 0 (det W ~ Omega^3)")
    if abs(iy - iz) <= _REL_ZERO * max(iy, iz):
        raise InputError("body.inertia", "unobservable: a1 = (Iy - Iz)/Ix is 0 (Iy = Iz)")
    if abs(iz - ix) <= _REL_ZERO * max(iz, ix):
        raise InputError("body.inertia", "unobservable: a2 = (Iz - Ix)/Iy is 0 (Iz = Ix)")
    if abs(gamma) <= _REL_ZERO:
        raise InputError("sensor.axis", "unobservable: gamma (z component of the sensing axis) is 0")
    mixed = a[1] * beta**2 - a[0] * alpha**2
    if abs(mixed) <= _REL_ZERO * (abs(a[1]) * beta**2 + abs(a[0]) * alpha**2 + _REL_ZERO):
        raise InputError(
            "sensor.axis",
            f"unobservable: a2 beta^2 - a1 alpha^2 = 0 (alpha={alpha:.6g}, beta={beta:.6g}, "
            f"a1={a[0]:.6g}, a2={a[1]:.6g})",
        )


def check_observer_poles(poles):
    """Validate desired observer poles: three, Re < 0, complex ones in conjugate pairs.

    Returns them as a complex array; raises InputError("observer.poles", ...) otherwise.
    """
    try:
        mu = np.asarray(poles, dtype=complex).ravel()
    except (TypeError, ValueError):
        raise InputError("observer.poles", f"must be numbers, got {poles!r}") from None
    if mu.size != 3:
        raise InputError("observer.poles", f"need exactly 3 poles (state dimension), got {mu.size}")
    if not np.all(np.isfinite(mu)):
        raise InputError("observer.poles", f"must be finite, got {mu}")
    if np.any(mu.real >= 0):
        raise InputError("observer.poles", f"need negative real parts for a converging observer, got {mu}")
    # Real coefficients of theta(s) need every complex pole matched by its conjugate.
    scale = max(1.0, float(np.max(np.abs(mu))))
    unmatched = list(mu[np.abs(mu.imag) > 1e-12 * scale])
    while unmatched:
        p = unmatched.pop()
        j = int(np.argmin([abs(q - np.conj(p)) for q in unmatched])) if unmatched else -1
        if j < 0 or abs(unmatched[j] - np.conj(p)) > 1e-9 * scale:
            raise InputError("observer.poles", f"complex pole {p} has no conjugate partner")
        unmatched.pop(j)
    return mu


def check_gains(inertia, spin_rate, gains):
    """Require A + K Hurwitz for K = diag(k) (Lebedev 1976, text before eq. 4.7).

    Returns k as an array; raises InputError("control.gains", ...) otherwise.
    """
    k = np.asarray(gains, dtype=float)
    if k.shape != (3,) or not np.all(np.isfinite(k)):
        raise InputError("control.gains", f"must be three numbers k1, k2, k3 [1/s], got {gains}")
    _, A = lebedev_matrices(inertia, spin_rate)
    ev = np.linalg.eigvals(A + np.diag(k))
    if np.any(ev.real >= 0):
        raise InputError("control.gains", f"A + K is not stable: eigenvalues {np.round(ev, 6)}")
    return k


def observer_gain(inertia, spin_rate, sensor_axis, poles):
    """Observer gain l placing eig(A - l C) at `poles` (repeated poles allowed).

    Lebedev 1976, text after eq. 4.7: l = T^-1 L with T = [t1 t2 t3]' (rows),
    t1 = A'^2 C' + alpha1 A'C' + alpha2 C', t2 = A'C' + alpha1 C', t3 = C', where
    det(sI - A) = s^3 + alpha1 s^2 + alpha2 s + alpha3, theta(s) = prod(s - mu_i) =
    s^3 + beta1 s^2 + beta2 s + beta3, and L_{4-i} = beta_i - alpha_i.
    (det T = -det W, so l exists iff the pair (A, C) is observable.)
    """
    check_observable(inertia, spin_rate, sensor_axis)
    _, A = lebedev_matrices(inertia, spin_rate)
    return ackermann_gain(A, sensor_axis, poles)


def ackermann_gain(A, sensor_axis, poles):
    """l with eig(A - l C) = poles for any observable 3x3 A and C = p' (the T^-1 L construction).

    The same formulas as `observer_gain` (Lebedev 1976, text after eq. 4.7) with A general;
    raises InputError("sensor.axis", ...) when det T = -det W vanishes (pair unobservable).
    """
    desired = np.poly(check_observer_poles(poles)).real
    A = np.asarray(A, dtype=float)
    c = np.asarray(sensor_axis, dtype=float)
    alpha = np.poly(A).real  # (1, alpha1, alpha2, alpha3)
    beta = desired           # (1, beta1, beta2, beta3)
    At = A.T
    t1 = At @ At @ c + alpha[1] * (At @ c) + alpha[2] * c
    t2 = At @ c + alpha[1] * c
    t3 = c
    T = np.vstack([t1, t2, t3])
    scale = max(np.abs(At @ At @ c).max(), 1e-300) * max(np.abs(At @ c).max(), 1e-300)
    if abs(np.linalg.det(T)) <= _REL_ZERO * scale:
        raise InputError("sensor.axis", f"unobservable: det W = {np.linalg.det(T):.3g} for this A and p")
    L = np.array([beta[3] - alpha[3], beta[2] - alpha[2], beta[1] - alpha[1]])
    return np.linalg.solve(T, L)


def gyrostat_error_matrix(inertia, spin_rate, momentum):
    """A + I^-1 [H x]: the observer error dynamics when internal momentum H is present.

    A CMG cluster holding H that compensates w x H with the *estimate* w_hat leaves the body
    a torque (w_hat - w) x H = H x e (e = x - z) that eq. 4.6 does not model, so the error obeys
    e' = (A + I^-1 [H x] - l C) e + ... (our extension: the paper's body has external torques).
    It is `gyrostat_jacobian` at w = (0, 0, Omega): there I^-1 ([(I w) x] - [w x] I) is A of
    Lebedev 1976, eq. 4.2. `momentum` may be one H (3,) or a stack (N, 3), giving (3, 3) or (N, 3, 3).
    """
    moments = principal_moments("body.inertia", inertia)
    return gyrostat_jacobian(moments, [0.0, 0.0, float(spin_rate)], momentum)


def gyrostat_jacobian(moments, w, momentum) -> np.ndarray:
    """d/dw of w' = I^-1 ((I w + H) x w), the free body holding internal momentum H:
    I^-1 ([(I w + H) x] - [w x] I), `moments` = (Ix, Iy, Iz) [kg m^2], w [rad/s], H [N m s];
    moments, w and H may be stacks (..., 3) (a batch's worlds), giving (..., 3, 3).

    At w = (0, 0, Omega) it is `gyrostat_error_matrix` (A + I^-1 [H x]). Once the loop is closed
    it is also the linearisation of the observer error: the body feels M - w x I w + H x e and
    eq. 4.6 models M - w_hat x I w_hat, so e' = J(w_hat, H) e - l C e + O(e^2) (docs/theory/lebedev.md
    "Non-zero total momentum").
    """
    moments = np.asarray(moments, float)
    w = np.asarray(w, float)
    L = moments * w + np.asarray(momentum, float)
    if L.ndim == 1:  # one (w, H), as every control period with measured momentum asks: the quick way
        return np.array([[0.0, -L[2] + w[2] * moments[1], L[1] - w[1] * moments[2]],
                         [L[2] - w[2] * moments[0], 0.0, -L[0] + w[0] * moments[2]],
                         [-L[1] + w[1] * moments[0], L[0] - w[0] * moments[1], 0.0]]) / moments[:, None]
    w = np.broadcast_to(w, L.shape)
    zero = np.zeros(L.shape[:-1])
    i0, i1, i2 = moments[..., 0], moments[..., 1], moments[..., 2]
    return np.stack([np.stack([zero, -L[..., 2] + w[..., 2] * i1, L[..., 1] - w[..., 1] * i2], -1),
                     np.stack([L[..., 2] - w[..., 2] * i0, zero, -L[..., 0] + w[..., 0] * i2], -1),
                     np.stack([-L[..., 1] + w[..., 1] * i0, L[..., 0] - w[..., 0] * i1, zero], -1)],
                    -2) / moments[..., :, None]


def lebedev_torque(inertia, k, z):
    """Control torque M_i = I_i k_i z_i [N m] from the state estimate z (Lebedev 1976, eq. 4.7).

    Task 1 (spin at Omega) and Task 2 (detumble, section 5) use the same law; for Task 2
    the observer is built with Omega = Omega*, a small admissible residual spin.
    """
    return np.asarray(inertia, dtype=float) * np.asarray(k, dtype=float) * np.asarray(z, dtype=float)


class LebedevObserver:
    """Discrete-time realisation of the continuous observers (3.1) and (4.6).

    Between two samples the input u is held (zero-order hold), y is held too or
    interpolated linearly to the newer sample (`y_end`), and the continuous observer ODE
    is integrated with classical RK4 in equal
    substeps no longer than `max_substep` (RK4 rather than an exact ZOH matrix because
    eq. 4.6 contains the quadratic F(z); A - lC has |entries| ~ 40 1/s in the paper's
    example, so substeps of 0.05 s keep h*|A - lC| ~ 1, well inside RK4's region).

    Holding y over the period delays the innovation, and |l| is large (~40 1/s in the
    example), so the period must stay short. Measured on the section-6 example (RK4
    truth, t* = 150 s), max |w - (0,0,1)| deg/s at 700 s: continuous 7.6e-7; dt = 0.05 s
    1.2e-6; 0.1 s 2.7e-6; 0.2 s 4.9e-5; 0.25 s 4.4e-4; dt = 0.5 s diverges. The held y
    costs a deviation from the continuous loop first order in the period (0.32 deg/s at
    0.05 s); interpolated, 0.0078 deg/s (docs/theory/lebedev.md "One gyro", bench/bench_lebedev_rates.py).

    State z estimates the deviation x = (wx, wy, wz - Omega); y is the raw gyro output
    p . w [rad/s]; the innovation uses y_dev = y - gamma Omega, since y = C x + gamma Omega.
    """

    def __init__(self, inertia, spin_rate, sensor_axis, poles, max_substep=0.05, design_momentum=None,
                 measured_momentum=False):
        self.inertia = principal_moments("body.inertia", inertia)
        self.spin_rate = float(spin_rate)
        self.C = check_unit_vector(sensor_axis, "sensor.axis")
        self.poles = check_observer_poles(poles)
        self.l = observer_gain(self.inertia, self.spin_rate, self.C, poles)
        # Closed-loop gain: the paper's l, or l for A + I^-1 [H x] when the actuators hold H.
        self.l_closed = self.l if design_momentum is None else ackermann_gain(
            gyrostat_error_matrix(self.inertia, self.spin_rate, design_momentum), self.C, poles)
        # measured_momentum: the model and the gain follow the momentum H the actuators report
        # (docs/theory/lebedev.md "Non-zero total momentum"); without it H is ignored, as in the paper
        self.measured_momentum = bool(measured_momentum)
        # the information filter's rate a: its steady poles for a torque-free spin sit 2a left of
        # eig(A) (testbed.math.information_filter), so half the slowest wanted rate
        self.decay = float(np.min(-self.poles.real)) / 2
        self.info: np.ndarray | None = None
        self.a, self.A = lebedev_matrices(self.inertia, self.spin_rate)
        # the fixed-gain derivative's constants as floats (_fixed_gain_derivative)
        self._c_floats, self._a_floats = self.C.tolist(), self.a.tolist()
        self._l_floats, self._l_closed_floats = self.l.tolist(), self.l_closed.tolist()
        if not max_substep > 0:
            raise InputError("observer.max_substep", f"must be > 0, got {max_substep}")
        self.max_substep = float(max_substep)
        self.z = np.zeros(3)
        self._startup_cache: tuple = (None, None)  # (H, startup_model(H)): H stays while the actuators idle

    def startup_model(self, momentum=None):
        """(A_s, d) of the start-up model z' = A_s z + d (+ F(z) with measured momentum).

        The paper's (3.1): A, 0. With measured momentum the idle actuators hold H fixed in the
        body, which then obeys I w' = -w x I w + H x w exactly; H x w = H x x + Omega H x e_z
        is linear in x, so the model gains A_s = A + I^-1 [H x] (gyrostat_error_matrix) and the
        drift d = Omega I^-1 (H x e_z) (our extension).
        """
        if not self.measured_momentum or momentum is None:
            return self.A, np.zeros(3)
        h = np.asarray(momentum, float)
        key = tuple(h.tolist())
        if self._startup_cache[0] != key:  # built once, not at every evaluation of the derivative
            drift = self.spin_rate * np.array([h[1], -h[0], 0.0]) / self.inertia
            self._startup_cache = (key, (gyrostat_error_matrix(self.inertia, self.spin_rate, h), drift))
        return self._startup_cache[1]

    def start(self, momentum=None):
        """The observer's state at the start of the start-up phase: z = 0 (eq. 3.1) or, with
        measured momentum H, the idle body taken at rest, w_hat = 0 (z = -Omega e_z: the body
        has not been spun up, and the linearisation there, I^-1 [H x], is the free gyrostat's
        at small rates), with the information Pi the filter gathers from nothing over
        INITIAL_HORIZON_RATES / a seconds of that pair held
        (testbed.math.information_filter.gathered_information; positive definite iff the
        pair is observable)."""
        self.reset()
        if self.measured_momentum and momentum is not None:
            self.z = np.array([0.0, 0.0, -self.spin_rate])
            matrix = gyrostat_jacobian(self.inertia, np.zeros(3), momentum)
            self.info = gathered_information(matrix, self.decay, self.C, INITIAL_HORIZON_RATES / self.decay)

    def _filtered(self, state, model, y_dev, momentum):
        """d/dt of (z, Pi) for the information filter on the gyrostat's linearisation at the
        estimate, J(w_hat, H) (module testbed.math.information_filter): z' = model + l (y_dev - C z),
        l = Pi^-1 C."""
        z, info = state[:3], state[3:].reshape(3, 3)
        jacobian = gyrostat_jacobian(self.inertia, z + [0.0, 0.0, self.spin_rate], momentum)
        gain = filter_gain(info, self.C)
        return np.concatenate([model + gain * (y_dev - self.C @ z),
                               information_rate(jacobian, info, self.decay, self.C).ravel()])

    def startup_derivative(self, state, y_dev, momentum=None):
        """d/dt of the observer state during start-up (the body uncontrolled).

        Paper (eq. 3.1): z' = A z + l (y_dev - C z). With measured momentum H the model is the free
        gyrostat itself, z' = A_H z + d + F(z) (`startup_model`; exact, not linearised about the
        wanted spin the idle body is far from), and the gain is the information filter's for its
        linearisation at the estimate (docs/theory/lebedev.md "Non-zero total momentum"); the state is (z, Pi)."""
        z = state[:3]
        matrix, drift = self.startup_model(momentum)
        if not self.measured_momentum or momentum is None:  # (A z + d) + l e, in plain floats as below
            return np.array(startup_rates((matrix @ z).tolist(), drift.tolist(), self._l_floats, self._c_floats,
                                          z.tolist(), y_dev))
        return self._filtered(state, matrix @ z + drift + lebedev_nonlinearity(self.a, z), y_dev, momentum)

    def closed_derivative(self, state, y_dev, u, momentum=None, compensated=None):
        """d/dt of the observer state once the loop is closed: z' = A z + l (y_dev - C z) + F(z) + u
        (Lebedev 1976, eq. 4.6), l the fixed `l_closed`, or with measured momentum H the information
        filter's gain for J(w_hat, H), the linearisation of the error dynamics (docs/theory/lebedev.md "Non-zero
        total momentum"; the state is then (z, Pi)).

        `compensated` (measured momentum): the gyroscopic torque w_k x H_k [N m] the actuators were
        commanded to cancel when u was set, held since; the bus then feels M + w_k x H_k - w x H
        (I w' = -w x (I w + H) - H', H' = -(M + w_k x H_k)), whose estimate at w_hat adds
        (w_k x H_k - w_hat x H) / I to the model. Without it the compensation is taken to follow
        w_hat continuously (the continuous loop)."""
        z = state[:3]
        if not self.measured_momentum or momentum is None:
            return self._fixed_gain_derivative(z, y_dev, np.asarray(u, dtype=float).tolist())
        model = self.A @ z + lebedev_nonlinearity(self.a, z) + u
        if compensated is not None:
            model = model + (compensated - cross3(z + [0.0, 0.0, self.spin_rate], momentum)) / self.inertia
        return self._filtered(state, model, y_dev, momentum)

    def _fixed_gain_derivative(self, z, y_dev, u: list) -> np.ndarray:
        """A z + l_closed (y_dev - C z) + F(z) + u (`closed_derivative` with the fixed gain; u as
        three floats, `fixed_gain_rates`). Plain floats but for A z (numpy's matmul, whose
        rounding it keeps): RK4 evaluates it four times a control period, and numpy's calls on
        3-vectors cost more than their arithmetic; the constants' floats are taken once
        (`__init__`), u's once a period (`step`)."""
        return np.array(fixed_gain_rates((self.A @ z).tolist(), self._l_closed_floats, self._a_floats,
                                         self._c_floats, z.tolist(), y_dev, u))

    def hold_total_momentum(self, modelled, measured) -> None:
        """Re-anchor the estimate on a measured internal momentum: keep the total momentum in
        body axes the estimate stands for, L_b = I w_hat + H, while H moves from the value the
        model reached (`modelled`) to the one measured (`measured`) [N m s]: w_hat -= I^-1 dH.

        Why it is right: the body's L_b' = L_b x w holds exactly whatever the actuators exchange
        with it (no H' in it), and w = I^-1 (L_b - H), so H enters w algebraically. The observer's
        model is that motion written in w, I w' = -w x (I w + H) - H' with H' the held command's;
        a momentum the command does not contain, dH, would otherwise stay in w_hat as an
        integrated torque error. Writing the error as eps = I^-1 (L_b_hat - L_b) =
        e + I^-1 (H_model - H), it obeys the filter's error equation eps' = (J - l C) eps + f with
        a forcing f = -(J - l C) I^-1 d - I^-1 (w x d) proportional to d = H_model - H, the
        momentum the model has missed since the last sample (reset to the measurement error by
        this call), not to d'. So the decay bound V = eps' Pi eps, V' <= -2 a V
        (testbed.math.information_filter) holds for eps with the gain and Pi unchanged, forced by
        a d that no longer accumulates (docs/theory/lebedev.md "Non-zero total momentum")."""
        self.z = self.z - (np.asarray(measured, float) - np.asarray(modelled, float)) / self.inertia

    def state(self, momentum=None) -> np.ndarray:
        """The observer's state: z, with measured momentum followed by Pi (row-major; `start`
        with the first momentum given when it was not started with one)."""
        if not self.measured_momentum or momentum is None:
            return self.z
        if self.info is None:
            self.start(momentum)
        return np.concatenate([self.z, self.info.ravel()])

    def reset(self, z0=None):
        """Set the estimate (default z = 0, as at the start of the start-up phase, eq. 3.1); the
        information filter starts again (`start`) at the next momentum given."""
        self.z = np.zeros(3) if z0 is None else np.asarray(z0, dtype=float).copy()
        self.info = None

    def substeps(self, dt: float) -> int:
        """How many equal RK4 substeps integrate an interval of dt [s]: the fewest no longer than max_substep."""
        return max(1, math.ceil(dt / self.max_substep - 1e-9))

    def _advance(self, rhs_of_y, state, y, dt, y_end=None):
        if not dt > 0:
            raise InputError("control.period", f"must be > 0, got {dt}")
        y_dev = float(y) - self.C[2] * self.spin_rate
        n = self.substeps(dt)
        if y_end is None:  # zero-order hold: y over the interval is the sample at its start
            rhs = lambda s, z: rhs_of_y(z, y_dev, s)  # noqa: E731
        else:              # first-order hold: y moves linearly to the sample at its end
            slope = float(y_end) - float(y)
            rhs = lambda s, z: rhs_of_y(z, y_dev + s * slope, s)  # noqa: E731
        state = rk4_steps(rhs, state, dt, n)
        self.z = state[:3]
        if state.size > 3:
            self.info = state[3:].reshape(3, 3)
        return self.z

    def startup_step(self, y, dt, y_end=None, momentum=None):
        """Advance the start-up observer z' = A z + l (y_dev - C z) by dt (Lebedev 1976, eq. 3.1).

        No F(z) and no u: the body is uncontrolled and still far from the spin that F is
        expanded about, and with F(z) and the paper's fixed gain the estimate stalls (SEEDS §000:
        ~6 deg/s error against ~0.2 deg/s without it). `y` is the sample at the start of the
        interval; with `y_end` (the sample at its end) y is interpolated linearly between them.
        With measured momentum H: the free gyrostat and the information filter
        (`startup_derivative`).
        """
        return self._advance(lambda state, y_dev, _: self.startup_derivative(state, y_dev, momentum),
                             self.state(momentum), y, dt, y_end)

    def step(self, y, u, dt, y_end=None, momentum=None, momentum_rate=None, compensated=None):
        """Advance z' = A z + l (y_dev - C z) + F(z) + u by dt (Lebedev 1976, eq. 4.6).

        u = M / I [rad/s^2] is the input applied over this period; `y`, `y_end` as in
        `startup_step`; the gain and `compensated` as in `closed_derivative`, with the momentum
        H(s) = H + s dt H' moving at the held rate `momentum_rate` over the interval (H held
        when it is not given).
        """
        u = np.asarray(u, dtype=float)
        if not self.measured_momentum or momentum is None:  # the fixed gain: u's floats once a period
            held = u.tolist()
            rhs = lambda state, y_dev, _: self._fixed_gain_derivative(state[:3], y_dev, held)  # noqa: E731
        elif momentum_rate is None:
            rhs = lambda state, y_dev, _: self.closed_derivative(state, y_dev, u, momentum, compensated)  # noqa: E731
        else:
            start, change = np.asarray(momentum, float), dt * np.asarray(momentum_rate, float)
            rhs = lambda state, y_dev, s: self.closed_derivative(state, y_dev, u, start + s * change,  # noqa: E731
                                                                 compensated)
        return self._advance(rhs, self.state(momentum), y, dt, y_end)

    def omega_estimate(self):
        """Estimated body rate w = z + (0, 0, Omega) [rad/s] (inverse of eq. 4.1)."""
        return self.z + np.array([0.0, 0.0, self.spin_rate])
