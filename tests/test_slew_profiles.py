"""Smooth rest-to-rest slew profiles (versine, s-curve) and shaped programs: the program's
attitude, rate and acceleration agree with each other by finite differences, meet the closed-form
end states, and the acceleration's spectrum is the closed form's (its zeros included)."""

from __future__ import annotations

import numpy as np
import pytest

from testbed.errors import InputError
from testbed.guidance.program_trajectory import ProgramTrajectory
from testbed.guidance.rest_to_rest_profiles import RestToRestProfile
from testbed.math.quaternion import quat_angle, quat_conj, quat_from_axis_angle, quat_mul
from testbed.scenario.schema import load
from testbed.guidance.slew import SlewParams
from testbed.shaping.shapers import shaper_for

AXIS = np.array([0.3, -0.5, 0.81])
AXIS = AXIS / np.linalg.norm(AXIS)
Q0 = quat_from_axis_angle(np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5]), 0.7)
ANGLE, T = np.radians(47.0), 13.0
PROFILES = [RestToRestProfile("versine", T), RestToRestProfile("s_curve", T, jerk_fraction=0.6, coast_fraction=0.2),
            RestToRestProfile("s_curve", T, shaper_for("zvd", [0.4], [0.03]), jerk_fraction=1.0),
            RestToRestProfile("cubic", T, shaper_for("zv", [0.23, 0.61], [0.0, 0.05]))]


@pytest.mark.parametrize("profile", PROFILES, ids=["versine", "s_curve", "s_curve_zvd", "cubic_zv2"])
def test_program_rate_and_acceleration_are_the_attitude_s_derivatives(profile):
    """ω = 2 vec(q~ q') and ω' by central differences (h = 1e-4 s: truncation ~ h² ψ''' ~ 1e-9,
    round-off 1e-16/h ~ 1e-12), at 60 times across the slew and its shaper: 1e-7 rad/s(²)."""
    program = ProgramTrajectory.eigen_axis_slew(Q0, AXIS, ANGLE, T, profile)
    h = 1e-4
    for t in np.linspace(0.01, profile.end - 0.01, 60):
        dq = (program.attitude(t + h) - program.attitude(t - h)) / (2 * h)
        rate = 2 * quat_mul(quat_conj(program.attitude(t)), dq)[1:]
        assert np.allclose(program.rate(t), rate, atol=1e-7)
        accel = (program.rate(t + h) - program.rate(t - h)) / (2 * h)
        assert np.allclose(program.acceleration(t), accel, atol=1e-7)
        assert abs(program.rate(t) @ AXIS) == pytest.approx(np.linalg.norm(program.rate(t)), abs=1e-12)  # eigen axis


@pytest.mark.parametrize("profile", PROFILES[:3], ids=["versine", "s_curve", "s_curve_zvd"])
def test_smooth_profiles_start_and_end_at_rest_with_zero_acceleration(profile):
    """q(0) = q0, q(end) = q0 ∘ (axis, angle), ω = ω' = 0 at both ends (to round-off), and rest after."""
    program = ProgramTrajectory.eigen_axis_slew(Q0, AXIS, ANGLE, T, profile)
    target = quat_mul(Q0, quat_from_axis_angle(AXIS, ANGLE))
    assert quat_angle(quat_mul(quat_conj(program.attitude(0.0)), Q0)) < 1e-12
    for t in (profile.end, profile.end + 5.0):
        assert quat_angle(quat_mul(quat_conj(program.attitude(t)), target)) < 1e-12
    for t in (0.0, 1e-9, profile.end - 1e-9, profile.end):
        assert np.linalg.norm(program.rate(t)) < 1e-8 and np.linalg.norm(program.acceleration(t)) < 1e-6


def test_versine_and_s_curve_peak_rates_match_the_closed_form():
    """Versine: peak rate 2θ/T at T/2. S-curve with ramps τ_j = r_j/4, coast τ_v: peak rate
    θ / (T (2τ_j + τ_a + τ_v)), τ_a = (1 - r_j - τ_v)/2 (the symmetric profile's area rule)."""
    program = ProgramTrajectory.eigen_axis_slew(Q0, AXIS, ANGLE, T, RestToRestProfile("versine", T))
    assert np.linalg.norm(program.rate(T / 2)) == pytest.approx(2 * ANGLE / T, rel=1e-14)
    rj, rv = 0.6, 0.2
    tj, ta = rj / 4, (1 - rj - rv) / 2
    program = ProgramTrajectory.eigen_axis_slew(Q0, AXIS, ANGLE, T, RestToRestProfile("s_curve", T, jerk_fraction=rj,
                                                                                     coast_fraction=rv))
    assert np.linalg.norm(program.rate(T / 2)) == pytest.approx(ANGLE / (T * (2 * tj + ta + rv)), rel=1e-12)


def test_cubic_profile_is_the_papers_cubic():
    """The shape-function path with the cubic equals SEEDS §004's coefficients (eq. 13) to round-off."""
    plain = ProgramTrajectory.eigen_axis_slew(Q0, AXIS, ANGLE, T)
    shaped = ProgramTrajectory.eigen_axis_slew(Q0, AXIS, ANGLE, T, RestToRestProfile("cubic", T))
    for t in np.linspace(0, T, 17):
        for a, b in zip(plain.state(t), shaped.state(t)):
            assert np.allclose(a, b, atol=1e-15)


def _fourier(profile, freqs, n=40001):
    """∫ g''(t) e^{-i 2π f t} dt over the profile (trapezoid on n points: error ~ (f dt)² ~ 1e-8)."""
    t = np.linspace(0.0, profile.end, n)
    accel = np.array([profile(x)[2] for x in t])
    return np.array([np.trapezoid(accel * np.exp(-2j * np.pi * f * t), t) for f in freqs])


def test_versine_acceleration_spectrum_is_the_closed_form():
    """a(t) = (2π/T²) sin(2πt/T) on [0, T]: |A(f)| = (2π/T²) Ω 2|sin πfT| / |Ω² - (2πf)²|, Ω = 2π/T,
    zero at f = k/T for k >= 2."""
    profile = RestToRestProfile("versine", T)
    freqs = np.array([0.013, 0.05, 0.11, 0.2, 0.37, 2 / T, 3 / T])
    omega, w = 2 * np.pi / T, 2 * np.pi * freqs
    closed = (2 * np.pi / T**2) * omega * 2 * np.abs(np.sin(np.pi * freqs * T)) / np.abs(omega**2 - w**2)
    measured = np.abs(_fourier(profile, freqs))
    assert np.allclose(measured, closed, atol=1e-7 * closed.max())
    assert np.all(closed[-2:] < 1e-15)


def test_s_curve_acceleration_spectrum_is_the_closed_form():
    """The jerk is ±J over four ramps, J = 1/(τ_j (τ_j + τ_a)(2τ_j + τ_a + τ_v)) / T³ (unit
    displacement): A(f) = Σ h_k (e^{-iωt1} - e^{-iωt2}) / (iω)², zero at f = 1/(τ_j T) (the ramps' sinc)."""
    rj, rv = 0.8, 0.1
    profile = RestToRestProfile("s_curve", T, jerk_fraction=rj, coast_fraction=rv)
    tj, ta = rj / 4, (1 - rj - rv) / 2
    jerk = 1.0 / (tj * (tj + ta) * (2 * tj + ta + rv)) / T**3
    lengths = np.array([tj, ta, tj, rv, tj, ta, tj]) * T
    heights = jerk * np.array([1, 0, -1, 0, -1, 0, 1])
    edges = np.concatenate([[0], np.cumsum(lengths)])
    freqs = np.array([0.02, 0.07, 0.13, 0.3, 0.55, 1 / (tj * T), 2 / (tj * T)])
    w = 2 * np.pi * freqs
    closed = np.abs(sum(h * (np.exp(-1j * w * a) - np.exp(-1j * w * b)) for h, a, b in zip(heights, edges[:-1],
                                                                                          edges[1:])) / (1j * w) ** 2)
    measured = np.abs(_fourier(profile, freqs))
    assert np.allclose(measured, closed, atol=1e-7 * closed.max())
    assert np.all(closed[-2:] < 1e-12 * closed.max())


@pytest.mark.parametrize("fields, field", [({"profile": "versine", "final_rate_deg_s": [0, 0, 1]}, "pipeline.law.profile"),
                                           ({"jerk_fraction": 0.7, "coast_fraction": 0.5}, "pipeline.law.coast_fraction"),
                                           ({"profile": "wobble"}, "pipeline.law.profile"),
                                           ({"profile": "s_curve", "jerk_fraction": 1e-4}, "pipeline.law.jerk_fraction"),
                                           ({"shaper": {"type": "zv", "frequency_hz": [0.3], "damping_ratio": [1.2]}},
                                            "pipeline.law.shaper.damping_ratio[0]"),
                                           ({"settle_rate_deg_s": 0.01, "final_rate_deg_s": [0, 1, 0]},
                                            "pipeline.law.final_rate_deg_s")])
def test_slew_refuses_profiles_it_cannot_fly(fields, field):
    base = {"axis": [0, 0, 1], "angle_deg": 30.0, "duration_s": 20.0}
    with pytest.raises(InputError) as err:
        load(SlewParams, base | fields, "pipeline.law")
    assert err.value.field == field


@pytest.mark.parametrize("profile", [RestToRestProfile("cubic", 9.0), RestToRestProfile("versine", 9.0),
                                     RestToRestProfile("s_curve", 9.0, jerk_fraction=0.7, coast_fraction=0.1)],
                         ids=["cubic", "versine", "s_curve"])
def test_a_profile_s_residual_vibration_is_what_an_ode_mode_keeps(profile):
    """A damped mode x'' + 2ζωx' + ω²x = ω² g(t) driven by the profile (SciPy's ODE solver): the
    amplitude about x = 1 at the profile's end, over a unit step's, is `residual_vibration`
    (1e-6: the ODE's tolerance); a shaper multiplies it by its V(ω, ζ)."""
    from scipy.integrate import solve_ivp

    from testbed.guidance.rest_to_rest_profiles import residual_vibration
    from testbed.shaping.shapers import residual_vibration as shaper_vibration

    w, zeta = 2 * np.pi * 0.31, 0.04
    wd = w * np.sqrt(1 - zeta**2)
    sol = solve_ivp(lambda t, y: [y[1], w * w * (profile(t)[0] - y[0]) - 2 * zeta * w * y[1]], (0.0, profile.end),
                    [0.0, 0.0], method="DOP853", rtol=1e-11, atol=1e-13, max_step=0.05)
    x, v = sol.y[0, -1] - 1.0, sol.y[1, -1]
    step = 1 / np.sqrt(1 - zeta**2)  # a unit step leaves -e^{-σt}(cos ω_d t + σ/ω_d sin ω_d t)
    assert residual_vibration(profile, w, zeta) == pytest.approx(np.hypot(x, (v + zeta * w * x) / wd) / step, rel=1e-6)
    shaper = shaper_for("zv", [0.27], [0.02])
    shaped = RestToRestProfile(profile.kind, profile.duration, shaper, profile.jerk_fraction, profile.coast_fraction)
    assert residual_vibration(shaped, w, zeta) == pytest.approx(
        residual_vibration(profile, w, zeta) * float(shaper_vibration(shaper, w, zeta)), rel=1e-8)


def test_the_s_curve_leaves_no_ringing_at_its_ramp_frequency():
    """Undamped, the s-curve's residual is zero at f = k/(τ_j T) (its acceleration's sinc zeros),
    the versine's at f = k/T, k >= 2; the cubic leaves some at both (1e-9: quad's floor)."""
    from testbed.guidance.rest_to_rest_profiles import residual_vibration

    T, rj = 11.0, 0.6
    f_ramp = 1 / (rj / 4 * T)
    assert residual_vibration(RestToRestProfile("s_curve", T, jerk_fraction=rj), 2 * np.pi * f_ramp, 0.0) < 1e-9
    assert residual_vibration(RestToRestProfile("versine", T), 2 * np.pi * 3 / T, 0.0) < 1e-9
    assert residual_vibration(RestToRestProfile("cubic", T), 2 * np.pi * 3 / T, 0.0) > 1e-3
