"""Gravity gradient through MuJoCo: the libration of an uncontrolled bus about LVLH
(validation 1) against the linearised equations of motion, and the momentum a CMG cluster
soaks up in an inertial hold (validation 3) against a quadrature of 3 mu/r^3 (r x I r)
written here (docs/theory/environment.md)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

import testbed
from testbed.environment import libration
from testbed.environment.libration import fitted_frequencies as frequencies

MU = 3.986004418e14
RE = 6378137.0


def roll_yaw_frequencies(inertia, n):
    """The two roll-yaw frequencies of the linearised motion about LVLH (x roll along-track,
    y pitch opposite the orbit normal, z yaw nadir; Wie, *Space Vehicle Dynamics and Control*,
    sec. 7.2): Ix phi'' - n (Ix - Iy + Iz) psi' + 4 n^2 (Iy - Iz) phi = 0,
    Iz psi'' + n (Ix - Iy + Iz) phi' + n^2 (Iy - Ix) psi = 0, as the eigenvalues of the
    first-order system in (phi, psi, phi', psi')."""
    ix, iy, iz = inertia
    g = ix - iy + iz
    a = np.array([[0, 0, 1, 0], [0, 0, 0, 1],
                  [-4 * n**2 * (iy - iz) / ix, 0, 0, n * g / ix],
                  [0, -n**2 * (iy - ix) / iz, -n * g / iz, 0]])
    eigenvalues = np.linalg.eigvals(a)
    assert np.allclose(eigenvalues.real, 0.0, atol=1e-12 * n)  # the Lagrange region: neutrally stable
    return np.sort(np.unique(np.round(np.abs(eigenvalues.imag), 15)))


@pytest.mark.parametrize("inertia", [[1000, 1200, 600], [1500, 2000, 800], [420, 510, 260], [3.1, 4.0, 1.2]])
def test_the_closed_form_roll_yaw_frequencies_are_the_eigenvalues_of_the_linearised_motion(inertia):
    """Wie's quartic in w^2 (the metric's closed form) against the eigenvalues of the first-order
    system here: the same two numbers to round-off (1e-12); pitch n sqrt(3 (Ix - Iz)/Iy) by hand."""
    n = 1.1e-3
    np.testing.assert_allclose(libration.roll_yaw_frequencies(inertia, n), roll_yaw_frequencies(inertia, n),
                               rtol=1e-12)
    ix, iy, iz = inertia
    assert libration.pitch_frequency(inertia, n) == pytest.approx(n * math.sqrt(3 * (ix - iz) / iy), rel=1e-15)


@pytest.mark.parametrize(("inertia", "altitude_km"), [
    ([1000, 1200, 600], 500),    # the shipped scenario
    ([1500, 2000, 800], 900),    # neither the inertia nor the altitude of the scenario
], ids=["shipped", "other"])
def test_gravity_gradient_libration_frequencies(inertia, altitude_km):
    """Pitch at n sqrt(3 (Ix - Iz) / Iy) within 0.5 %, the two roll-yaw modes within 1 %
    (measured: pitch 0.03 % and 0.06 %, roll-yaw at most 0.13 % and 0.2 %: 0.2 deg starts,
    whose second-order coupling tones bias the fit of six turns of the slow mode that much)."""
    result = testbed.run("orbit_libration", overrides=[f"model.inertia_kg_m2={inertia}",
                                                       f"orbit.altitude_km={altitude_km}"])
    assert result.status == "ok", result.error
    t, q = result.trace["truth/quat_lvlh"]
    roll, pitch, yaw = (2 * np.arctan2(q[:, k], q[:, 0]) for k in (1, 2, 3))
    assert max(np.abs(roll).max(), np.abs(pitch).max(), np.abs(yaw).max()) < math.radians(2)
    n = math.sqrt(MU / (RE + altitude_km * 1e3) ** 3)
    ix, iy, iz = inertia
    assert frequencies(t, [pitch], 1)[0] == pytest.approx(n * math.sqrt(3 * (ix - iz) / iy), rel=5e-3)
    expected = roll_yaw_frequencies(inertia, n)
    np.testing.assert_allclose(frequencies(t, [roll, yaw], 2), expected, rtol=1e-2)
    # the scenario's own checks are these figures
    pitch_error = abs(frequencies(t, [pitch], 1)[0] / (n * math.sqrt(3 * (ix - iz) / iy)) - 1)
    assert result.metrics["pitch_libration_error_rel"] == pytest.approx(pitch_error, rel=1e-6, abs=1e-12)
    roll_yaw_error = np.max(np.abs(frequencies(t, [roll, yaw], 2) / expected - 1))
    assert result.metrics["roll_yaw_libration_error_rel"] == pytest.approx(roll_yaw_error, rel=1e-6, abs=1e-9)


def rigid_body_in_circular_orbit(times, q0, omega0, inertia, a, inclination):
    """Attitudes (w, x, y, z), body to ECI, at `times` [s] of a rigid body of principal inertia
    `inertia` [kg m^2] from q0 and the body rate omega0 [rad/s], under the gravity-gradient
    torque 3 mu/a^3 (u x I u) (u: the geocentric direction in body axes) on the Keplerian
    circular orbit of radius a [m] and inclination [rad], node on ECI x, at the node at t = 0:
    Euler's equations and q' = q (0, omega) / 2, integrated by SciPy's DOP853 at rtol 1e-12
    (the torque is evaluated at every stage: no hold of any order)."""
    n = math.sqrt(MU / a**3)
    p, s = np.array([1.0, 0.0, 0.0]), np.array([0.0, math.cos(inclination), math.sin(inclination)])
    big = np.diag(np.asarray(inertia, float))

    def derivative(t, y):
        q, w = y[:4] / np.linalg.norm(y[:4]), y[4:]
        u = Rotation.from_quat(q[[1, 2, 3, 0]]).inv().apply(math.cos(n * t) * p + math.sin(n * t) * s)
        torque = 3 * n**2 * np.cross(u, big @ u)
        qw, qx, qy, qz = q
        dq = 0.5 * np.array([-qx * w[0] - qy * w[1] - qz * w[2], qw * w[0] + qy * w[2] - qz * w[1],
                             qw * w[1] - qx * w[2] + qz * w[0], qw * w[2] + qx * w[1] - qy * w[0]])
        return np.concatenate([dq, (torque - np.cross(w, big @ w)) / np.diag(big)])

    solution = solve_ivp(derivative, (0.0, times[-1]), np.concatenate([q0, omega0]), method="DOP853",
                         rtol=1e-12, atol=1e-14, t_eval=times)
    return solution.y[:4].T


def libration_miss_deg(update_period_s: float) -> float:
    """The largest rotation angle [deg] between the MuJoCo truth and `rigid_body_in_circular_orbit`
    over 8 orbits at 650 km, 97.9 deg, of a body of inertia [420, 510, 260] kg m^2 started
    (1, -1.5, 2) deg off LVLH (no case of the repository), at the given environment update period."""
    inertia, altitude_km, inclination_deg = [420, 510, 260], 650, 97.9
    a = RE + altitude_km * 1e3
    eight_orbits = 8 * 2 * math.pi * math.sqrt(a**3 / MU)
    result = testbed.run("orbit_libration", overrides=[
        f"model.inertia_kg_m2={inertia}", f"orbit.altitude_km={altitude_km}", f"orbit.inclination_deg={inclination_deg}",
        f"sim.duration_s={eight_orbits:.0f}", "initial.quat=[0.99965732, 0.00872654, -0.01308997, 0.01745241]",
        f"environment.update_period_s={update_period_s}"])
    assert result.status == "ok", result.error
    t, q = result.trace["truth/quat"]
    _, omega = result.trace["truth/omega"]
    reference = rigid_body_in_circular_orbit(t, q[0], omega[0], inertia, a, math.radians(inclination_deg))
    miss = Rotation.from_quat(q[:, [1, 2, 3, 0]]).inv() * Rotation.from_quat(reference[:, [1, 2, 3, 0]])
    return float(np.degrees(miss.magnitude().max()))


@pytest.mark.slow
def test_the_libration_agrees_with_a_continuous_torque_to_second_order_in_the_update_period():
    """The gravity-gradient torque held at its midpoint extrapolation (midpoint_hold.py) against
    the torque evaluated continuously: over 8 orbits of a ~3 deg libration the attitudes agree
    within 0.005 deg at the shipped 5 s update (measured 6.7e-4 deg; the zero-order hold
    missed by 0.138 deg), and doubling the period quadruples the miss (measured 2.7e-3 deg at
    10 s: ratio 4.0; a first-order hold error would double it). The miss is well conditioned
    (a smooth phase error far above the reference's 1e-10 deg), so the ratio is pinned to 4 +- 0.6."""
    at_5 = libration_miss_deg(5.0)
    at_10 = libration_miss_deg(10.0)
    assert at_5 < 0.005
    assert at_10 / at_5 == pytest.approx(4.0, abs=0.6)


def _quat_matrices(q):
    """Body-to-world matrices of quaternions (w, x, y, z), by SciPy (scalar last), (N, 3, 3)."""
    return Rotation.from_quat(q[:, [1, 2, 3, 0]]).as_matrix()


def test_an_inertial_hold_stores_the_integral_of_the_gravity_gradient_torque():
    """Validation 3, shortened to 1500 s (the shipped run is 5 orbits): with no other torque the
    whole spacecraft's momentum changes by the torque's integral, and the bus holding still
    leaves it all in the cluster: R(q) H_body(t) = H(0) + int_0^t R(q) 3 mu/r^3 (r x I r) dt.
    The torque is evaluated here from the recorded orbit and attitude and the inertia MuJoCo
    gives at t = 0, and integrated by the trapezoidal rule on the 10 s trace samples (its error
    ~1e-5 of the integral; the 1 s zero-order hold of the applied torque, ~3e-4): within 1 % of
    the peak |H|. (The cluster's torque on the bus, -dH/dt, is minus the gradient torque.)"""
    from testbed.runner import prepare

    overrides = ["sim.duration_s=1500"]
    plant, _, _ = prepare(testbed.load("orbit_momentum_buildup", overrides))
    inertia = plant.locked_inertia()
    result = testbed.run("orbit_momentum_buildup", overrides=overrides)
    assert result.status == "ok", result.error
    t, q = result.trace["truth/quat"]
    _, r = result.trace["truth/orbit_position"]
    _, h_body = result.trace["truth/cmg_momentum"]
    to_world = _quat_matrices(q)
    r_body = np.einsum("nji,nj->ni", to_world, r)
    distance = np.linalg.norm(r_body, axis=1, keepdims=True)
    u = r_body / distance
    torque_world = np.einsum("nij,nj->ni", to_world, 3 * MU / distance**3 * np.cross(u, u @ inertia.T))
    stored = np.concatenate([np.zeros((1, 3)), np.cumsum((torque_world[1:] + torque_world[:-1]) / 2
                                                         * np.diff(t)[:, None], axis=0)])
    h_world = np.einsum("nij,nj->ni", to_world, h_body)
    peak = np.linalg.norm(h_world, axis=1).max()
    assert peak > 0.1  # N m s: the torque's secular part builds momentum
    assert np.abs(h_world - h_world[0] - stored).max() < 0.01 * peak


def _print_figures():  # pragma: no cover  (python tests/test_gravity_gradient.py: the measured errors)
    for inertia, altitude_km in ([1000, 1200, 600], 500), ([1500, 2000, 800], 900):
        result = testbed.run("orbit_libration", overrides=[f"model.inertia_kg_m2={inertia}",
                                                           f"orbit.altitude_km={altitude_km}"])
        t, q = result.trace["truth/quat_lvlh"]
        roll, pitch, yaw = (2 * np.arctan2(q[:, k], q[:, 0]) for k in (1, 2, 3))
        n = math.sqrt(MU / (RE + altitude_km * 1e3) ** 3)
        ix, iy, iz = inertia
        print(inertia, altitude_km, frequencies(t, [pitch], 1)[0] / (n * math.sqrt(3 * (ix - iz) / iy)) - 1,
              frequencies(t, [roll, yaw], 2) / roll_yaw_frequencies(inertia, n) - 1)


if __name__ == "__main__":
    _print_figures()
