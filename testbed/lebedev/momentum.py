"""Which total angular momenta one gyro can observe a spinning CMG spacecraft with.

Our extension of Lebedev (1976) to a body whose actuators hold momentum H (docs/theory/lebedev.md "Non-zero
total momentum"). With H the observer error obeys e' = (A_H - l C) e, A_H = A + I^-1 [H x]
(testbed.lebedev.observer.gyrostat_error_matrix), so the gain exists iff the pair
(A_H, C) is observable: det W(A_H) != 0, W = [C; C A_H; C A_H^2] (eq. 4.4 with A -> A_H).

At the wanted spin w = (0, 0, Omega) the total momentum in body axes is L = I Omega e_z + H,
and A_H depends on H only through L: its 2x2 block is [[0, (Iy Omega - L3)/Ix],
[(L3 - Ix Omega)/Iy, 0]] (the rigid body's A with Iz Omega replaced by L3), its other entries
L1, L2 over the moments. Expanding det W symbolically for L along z gives (checked against
numerical determinants on random bodies in tests/test_lebedev_momentum.py)

    det W = gamma (Ix Omega - L3)(Iy Omega - L3)(Ix (Ix Omega - L3) beta^2 + Iy (Iy Omega - L3) alpha^2) / (Ix^2 Iy^2),

which for H = 0 (L3 = Iz Omega) is eq. 4.5. So an axial total momentum is unobservable at
L3 = Ix Omega, at L3 = Iy Omega and at L3 = Omega (Ix^2 beta^2 + Iy^2 alpha^2) / (Ix beta^2 + Iy alpha^2)
between them (`axial_unobservable_momenta`). In general det W is a cubic in L; its zero set is
a surface through those three points. L is fixed in inertial space while the body turns under
it: whatever attitude the spin-up ends in, every end state is observable iff the ball |L| < r*
misses the surface, r* = `observable_momentum_radius` (the nearest zero of the cubic along any
ray from L = 0, which is observable whenever the rigid body is); r* is small (15.4 N m s for the
flagship's spacecraft, below Ix Omega = 21.8) because the surface bends towards L = 0 off the
z axis. The spin-up does not end in any attitude, though: L keeps its length, its angle to body
z is where the idle start-up left it (the free gyrostat turns L in the body: `idle_polar_angles`)
give or take the closed loop's few degrees, and at the end its transverse part turns with the
body, sweeping a circle. `check_momentum_observable` asks for the observer's information on
those circles (`end_state_information`); the measured tilts are in docs/theory/lebedev.md.
"""

from __future__ import annotations

import numpy as np

from testbed.errors import InputError
from testbed.math.information_filter import information_rate
from testbed.lebedev.observer import gyrostat_error_matrix, gyrostat_jacobian

DIRECTIONS = 96   # polar angles of the direction grid (twice as many azimuths) for r*
# How far the closed loop tilts the spin axis against L after the idle start-up has turned L in
# the body (measured 0.2 to 2.2 deg on six runs: docs/theory/lebedev.md), and the spacing of the angles searched.
CLOSED_LOOP_TILT_DEG = 5.0
BAND_STEP_DEG = 2.5
# least end-state information accepted, relative to the rigid body's: the gain l = Pi^-1 C may
# grow about 10 times the paper's, whose noise amplification is already 13 (docs/theory/lebedev.md "One gyro")
MIN_INFORMATION = 0.1


def observability_determinant(inertia, spin_rate, sensor_axis, total_momentum):
    """det [C; C A_H; C A_H^2] with H = L - I Omega e_z, for one L (3,) or a stack (N, 3)."""
    inertia = np.asarray(inertia, float)
    L = np.asarray(total_momentum, float)
    H = L - np.array([0.0, 0.0, inertia[2] * spin_rate])
    A_H = gyrostat_error_matrix(inertia, spin_rate, H)
    c = np.asarray(sensor_axis, float)
    row1 = np.einsum("j,...jk->...k", c, A_H)
    row2 = np.einsum("...j,...jk->...k", row1, A_H)
    return np.linalg.det(np.stack([np.broadcast_to(c, row1.shape), row1, row2], -2))


def axial_unobservable_momenta(inertia, spin_rate, sensor_axis) -> np.ndarray:
    """The three L3 [N m s] at which a total momentum along z is unobservable (module doc)."""
    ix, iy, _ = np.asarray(inertia, float)
    alpha, beta, _ = np.asarray(sensor_axis, float)
    w = float(spin_rate)
    weighted = w * (ix**2 * beta**2 + iy**2 * alpha**2) / (ix * beta**2 + iy * alpha**2)
    return np.array([ix * w, iy * w, weighted])


def _directions(n: int = DIRECTIONS) -> np.ndarray:
    polar = (np.arange(n) + 0.5) * np.pi / n
    azimuth = np.arange(2 * n) * np.pi / n
    p, a = np.meshgrid(polar, azimuth)
    return np.stack([np.sin(p) * np.cos(a), np.sin(p) * np.sin(a), np.cos(p)], -1).reshape(-1, 3)


def observable_momentum_radius(inertia, spin_rate, sensor_axis, n: int = DIRECTIONS):
    """(r*, L*): the largest |L| [N m s] whose whole ball one gyro observes, and the nearest
    unobservable total momentum L* (body axes). det W along a ray L = s u is a cubic in s,
    fitted exactly through four samples; r* is the least positive real root over a grid of
    directions u (2 n^2 of them)."""
    inertia = np.asarray(inertia, float)
    u = _directions(n)
    scale = float(np.max(inertia) * abs(spin_rate))
    samples = np.stack([observability_determinant(inertia, spin_rate, sensor_axis, s * scale * u)
                        for s in range(4)], -1)
    c3, c2, c1, c0 = np.linalg.solve(np.vander(np.arange(4.0), 4), samples.T)   # per direction
    # roots of each cubic: eigenvalues of its companion matrix (a cubic that degenerates to a
    # lower degree along a direction has fewer roots there; those directions are skipped)
    proper = np.abs(c3) > 1e-12 * np.max(np.abs([c3, c2, c1, c0]), axis=0)
    companion = np.zeros((int(proper.sum()), 3, 3))
    companion[:, 0, :] = -np.stack([c2, c1, c0], -1)[proper] / c3[proper, None]
    companion[:, 1, 0] = companion[:, 2, 1] = 1.0
    roots = np.linalg.eigvals(companion)
    real = (np.abs(roots.imag) <= 1e-9 * np.maximum(1.0, np.abs(roots))) & (roots.real > 0)
    first = np.where(real, roots.real, np.inf).min(axis=1)
    i = int(np.argmin(first))
    if not np.isfinite(first[i]):
        return np.inf, None
    return float(first[i]) * scale, float(first[i]) * scale * u[proper][i]


def end_held_momentum(moments, spin_rate, size: float, polar: float, phase) -> np.ndarray:
    """What the actuators hold at the end spin w = Omega e_z, H = L - I Omega e_z [N m s], body
    axes (..., 3), with L (|L| = `size`) at `polar` [rad] to body z and at azimuth `phase` [rad]
    (..., it turns in the body at -Omega: module doc)."""
    phase = np.asarray(phase, float)
    return np.stack([size * np.sin(polar) * np.cos(phase), size * np.sin(polar) * np.sin(phase),
                     np.full_like(phase, size * np.cos(polar) - moments[2] * spin_rate)], -1)


def end_polar_band(least_deg: float, largest_deg: float) -> np.ndarray:
    """The polar angles [deg] of L an end spin is searched at: [least, largest] widened by
    CLOSED_LOOP_TILT_DEG on each side within [0, 180], at most BAND_STEP_DEG apart, at least three."""
    low = max(0.0, least_deg - CLOSED_LOOP_TILT_DEG)
    high = min(180.0, largest_deg + CLOSED_LOOP_TILT_DEG)
    return np.linspace(low, high, max(3, int(np.ceil((high - low) / BAND_STEP_DEG)) + 1))


def end_state_information(inertia, spin_rate, sensor_axis, total_momentum, decay: float, polar_deg=None,
                          samples: int = 720) -> float:
    """The least information the measured-momentum observer holds at the end of a spin with total
    momentum L (body axes at t = 0), relative to the paper's rigid body: min over one turn of
    lambda_min(Pi(t)) / lambda_min(Pi_0).

    At the end the body spins at w = (0, 0, Omega) and L, fixed in inertial space, turns in the body
    at -Omega about z at its polar angle (`polar_deg`, default L's own): the error matrix
    J(t) = A + I^-1 [H(t) x], H = L(t) - I Omega e_z, is periodic, and the information filter's Pi
    (testbed.math.information_filter) settles on the periodic solution of its equation, found here
    by integrating it over one turn from the frozen solution and once more. The filter's gain is
    l = Pi^-1 C, so lambda_min bounds how far the gain can grow; Pi_0 is the steady Pi of the
    paper's pair (A, C), H = 0."""
    inertia = np.asarray(inertia, float)
    c = np.asarray(sensor_axis, float)
    L = np.asarray(total_momentum, float)
    size = float(np.linalg.norm(L))
    polar = np.arccos(np.clip(L[2] / size, -1, 1)) if polar_deg is None else np.radians(polar_deg)
    azimuth0 = np.arctan2(L[1], L[0])
    spin = np.array([0.0, 0.0, spin_rate])

    def jacobian(t):
        return gyrostat_jacobian(inertia, spin, end_held_momentum(inertia, spin_rate, size, polar,
                                                                  azimuth0 - spin_rate * t))

    def steady(matrix):
        shifted = matrix + decay * np.eye(3)
        from scipy.linalg import solve_continuous_lyapunov  # on use: at the top it would cost every command start-up time
        return solve_continuous_lyapunov(shifted.T, np.outer(c, c))

    turn = 2 * np.pi / abs(spin_rate)
    rhs = lambda t, p: information_rate(jacobian(t), p.reshape(3, 3), decay, c).ravel()  # noqa: E731
    times = np.linspace(turn, 2 * turn, samples)
    with np.errstate(under="ignore"):   # the step-size control's nextafter near 0 (harmless)
        from scipy.integrate import solve_ivp  # on use: at the top it would cost every command start-up time
        settle = solve_ivp(rhs, (0.0, turn), steady(jacobian(0.0)).ravel(), rtol=1e-8, atol=1e-12 * size)
        sol = solve_ivp(rhs, (turn, 2 * turn), settle.y[:, -1], rtol=1e-8, atol=1e-12 * size, t_eval=times)
    least = min(np.linalg.eigvalsh(p.reshape(3, 3))[0] for p in sol.y.T)
    rigid = np.linalg.eigvalsh(steady(gyrostat_jacobian(inertia, spin, np.zeros(3))))[0]
    return float(least / rigid)


def idle_polar_angles(inertia, momentum, omega0, duration: float) -> np.ndarray:
    """Angle [deg] between the total momentum L = I w + H and body z every second while the body
    idles for `duration` [s] (the last sample at `duration`) from w(0) = `omega0` with the
    actuators holding H: the free gyrostat, I w' = -w x (I w + H), solved with DOP853 (L keeps its
    length and turns in the body)."""
    inertia = np.asarray(inertia, float)
    held = np.asarray(momentum, float)
    rates = np.asarray(omega0, float)[:, None]
    if duration > 0.0:  # (no start-up: L where it starts)
        times = np.linspace(0.0, duration, max(2, int(duration) + 1))
        with np.errstate(under="ignore"):
            from scipy.integrate import solve_ivp
            rates = solve_ivp(lambda t, w: -np.cross(w, inertia * w + held) / inertia, (0.0, duration),
                              rates[:, 0], method="DOP853", rtol=1e-9, atol=1e-15, t_eval=times).y
    L = inertia[:, None] * rates + held[:, None]
    return np.degrees(np.arccos(np.clip(L[2] / np.linalg.norm(L, axis=0), -1.0, 1.0)))


def check_momentum_observable(inertia, spin_rate, sensor_axis, total_momentum, decay: float, field: str,
                              polar_range_deg: tuple[float, float] | None = None) -> None:
    """Refuse a total momentum L at whose end states the observer would hold less than
    MIN_INFORMATION of the rigid body's information (`end_state_information`), on the circles at
    the polar angles the spin can end at: `polar_range_deg` (the least and largest angle the idle
    start-up takes L to, `idle_polar_angles`) widened by CLOSED_LOOP_TILT_DEG, or L's own angle +- that."""
    L = np.asarray(total_momentum, float)
    size = float(np.linalg.norm(L))
    if size == 0.0:
        return
    if polar_range_deg is None:
        own = np.degrees(np.arccos(np.clip(L[2] / size, -1.0, 1.0)))
        polar_range_deg = (own, own)
    polars = end_polar_band(*polar_range_deg)
    least, polar = min((end_state_information(inertia, spin_rate, sensor_axis, L, decay, p), p) for p in polars)
    if least < MIN_INFORMATION:
        raise InputError(field, f"total angular momentum L = {np.array2string(L, precision=4)} N m s: one gyro cannot "
                                f"observe the spin it ends in (the observer's information falls to {least:.3g} of "
                                f"the rigid body's, below {MIN_INFORMATION}, with L at {polar:.1f} deg to the spin "
                                f"axis, |L| = {size:.4g})")
