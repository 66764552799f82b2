"""ZV and ZVD shapers (Singer & Seering 1990) on an independent plant: one damped second-order
mode integrated by SciPy's ODE solver. The residual vibration of a shaped command over that of
the unshaped one, each read the same time after its command ends, is the shaper's sensitivity
V(ω, ζ) at the plant's mode, tuned or detuned by ±10 %; on an undamped mode V has the closed forms |cos(πr/2)| (ZV) and cos²(πr/2) (ZVD), r the
plant's frequency over the design frequency."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from testbed.errors import InputError
from testbed.guidance.rest_to_rest_profiles import RestToRestProfile
from testbed.shaping.shapers import residual_vibration, shaper_for, zv, zvd

F_DESIGN_HZ = 0.37  # a mode no shipped scenario holds


def residual_amplitude(command, frequency_rad_s, zeta, t_end, t_read, breaks=()):
    """Amplitude of the free oscillation of q'' + 2ζω q' + ω² q = ω² u(t) about its rest q = u(∞) = 1,
    read at t_read (after every input has ended): √(x² + ((x' + ζω x)/ω_d)²), x = q - 1."""
    w, wd = frequency_rad_s, frequency_rad_s * np.sqrt(1 - zeta**2)
    y, t0 = np.zeros(2), 0.0
    for t1 in sorted({*breaks, t_end}):  # integrate piece by piece: the command has corners at the breaks
        if t1 <= t0:
            continue
        sol = solve_ivp(lambda t, s: [s[1], w * w * (command(t) - s[0]) - 2 * zeta * w * s[1]], (t0, t1), y,
                        method="DOP853", rtol=1e-11, atol=1e-13)
        y, t0 = sol.y[:, -1], t1
    sol = solve_ivp(lambda t, s: [s[1], w * w * (1.0 - s[0]) - 2 * zeta * w * s[1]], (t0, t_read), y,
                    method="DOP853", rtol=1e-11, atol=1e-13)
    x, v = sol.y[0, -1] - 1.0, sol.y[1, -1]
    return np.hypot(x, (v + zeta * w * x) / wd)


def shaped_step(shaper):
    return lambda t: float(np.sum(shaper.amplitudes[shaper.times <= t]))


@pytest.mark.parametrize("kind, closed_form", [("zv", lambda r: abs(np.cos(np.pi * r / 2))),
                                               ("zvd", lambda r: np.cos(np.pi * r / 2) ** 2)])
@pytest.mark.parametrize("ratio", [0.9, 1.0, 1.1])
def test_undamped_residual_matches_the_closed_form(kind, closed_form, ratio):
    """Undamped design, undamped plant at r = 0.9, 1, 1.1 of the design: V_ZV(±10 %) = 0.156,
    V_ZVD(±10 %) = 0.0245. The ODE's residual ratio to 1e-7 absolute (its tolerance 1e-11,
    a well-conditioned ratio of two O(1) amplitudes)."""
    w0 = 2 * np.pi * F_DESIGN_HZ
    shaper = shaper_for(kind, [F_DESIGN_HZ], [0.0])
    plant = ratio * w0
    t_read = shaper.duration + 3.0
    unshaped = residual_amplitude(lambda t: 1.0, plant, 0.0, 1e-9, 3.0)
    shaped = residual_amplitude(shaped_step(shaper), plant, 0.0, shaper.duration + 1e-9, t_read, shaper.times)
    assert shaped / unshaped == pytest.approx(closed_form(ratio), abs=1e-7)
    assert residual_vibration(shaper, plant, 0.0) == pytest.approx(closed_form(ratio), abs=1e-12)
    if ratio != 1.0:
        assert closed_form(ratio) == pytest.approx({"zv": 0.15643, "zvd": 0.024472}[kind], rel=1e-4)


@pytest.mark.parametrize("kind", ["zv", "zvd"])
@pytest.mark.parametrize("ratio", [0.9, 1.0, 1.1])
def test_damped_mode_detuned_residual_matches_the_sensitivity(kind, ratio):
    """A shaper designed for ζ = 0.04 at f0, on the same damping at 0.9, 1.0, 1.1 f0: the ODE's
    residual ratio equals V(ω, ζ) (Singer & Seering 1990, eq. 4) to 1e-7; tuned, V = 0 (the
    cancellation is exact in the closed form: 1e-12, the round-off floor of K = e^{-ζπ/√(1-ζ²)})."""
    zeta, w0 = 0.04, 2 * np.pi * F_DESIGN_HZ
    shaper = shaper_for(kind, [F_DESIGN_HZ], [zeta])
    plant = ratio * w0
    t_read = shaper.duration + 2.0
    unshaped = residual_amplitude(lambda t: 1.0, plant, zeta, 1e-9, 2.0)  # 2 s after its command, as the shaped
    shaped = residual_amplitude(shaped_step(shaper), plant, zeta, shaper.duration + 1e-9, t_read, shaper.times)
    predicted = float(residual_vibration(shaper, plant, zeta))
    assert shaped / unshaped == pytest.approx(predicted, abs=1e-7)
    if ratio == 1.0:
        assert predicted == pytest.approx(0.0, abs=1e-12)
    else:  # the ZVD shaper is the robust one: ~6x less residual than ZV at ±10 %
        assert predicted > 0.01 and (kind == "zv") == (predicted > 0.1)


@pytest.mark.parametrize("kind", ["zv", "zvd"])
@pytest.mark.parametrize("ratio", [0.9, 1.1])
def test_shaped_slew_profile_residual_falls_by_the_sensitivity(kind, ratio):
    """A flexible mode driven by a slew's angular acceleration, q'' + 2ζωq' + ω²q = -ψ''(t), along
    a versine rest-to-rest profile of 7 s, unshaped and shaped at a mode detuned by ±10 %: the
    residual ratio, each 1 s after its profile's end, is V(ω, ζ) of the shaper (a convolution
    keeps every mode's response ratio); 1e-5 relative: the ODE's tolerance on a 0.02-0.15 ratio."""
    zeta, f0, T = 0.02, 0.29, 7.0
    shaper = shaper_for(kind, [f0], [zeta])
    w = 2 * np.pi * f0 * ratio
    wd = w * np.sqrt(1 - zeta**2)

    def residual(profile):
        sol = solve_ivp(lambda t, s: [s[1], -profile(t)[2] - w * w * s[0] - 2 * zeta * w * s[1]],
                        (0.0, profile.end + 1.0), [0.0, 0.0], method="DOP853", rtol=1e-11, atol=1e-14,
                        max_step=0.05)
        x, v = sol.y[:, -1]
        return np.hypot(x, (v + zeta * w * x) / wd)

    unshaped = residual(RestToRestProfile("versine", T))
    shaped = residual(RestToRestProfile("versine", T, shaper))
    assert shaped / unshaped == pytest.approx(float(residual_vibration(shaper, w, zeta)), rel=1e-5)


def test_shapers_closed_form_amplitudes_and_times():
    """ZV: (1, K)/(1+K) at (0, Td/2); ZVD: (1, 2K, K²)/(1+K)² at (0, Td/2, Td), K = e^{-ζπ/√(1-ζ²)}."""
    w, zeta = 3.0, 0.1
    k = np.exp(-zeta * np.pi / np.sqrt(1 - zeta**2))
    half = np.pi / (w * np.sqrt(1 - zeta**2))
    s = zv(w, zeta)
    assert np.allclose(s.amplitudes, [1 / (1 + k), k / (1 + k)], rtol=1e-15) and np.allclose(s.times, [0, half])
    s = zvd(w, zeta)
    assert np.allclose(s.amplitudes, np.array([1, 2 * k, k * k]) / (1 + k) ** 2, rtol=1e-15)
    assert np.allclose(s.times, [0, half, 2 * half])
    two = shaper_for("zv", [0.5, 1.3], [0.01, 0.02])  # two modes: both cancelled, amplitudes sum to 1
    assert two.amplitudes.sum() == pytest.approx(1.0, abs=1e-15) and len(two.times) == 4
    for f, z in ((0.5, 0.01), (1.3, 0.02)):
        assert residual_vibration(two, 2 * np.pi * f, z) == pytest.approx(0.0, abs=1e-12)  # round-off floor


@pytest.mark.parametrize("frequencies, zetas, field", [([0.0], [0.0], "frequency_hz"), ([1.0], [1.0], "damping_ratio"),
                                                       ([1.0, 2.0], [0.1], "damping_ratio"),
                                                       ([0.1] * 5, [0.01] * 5, "frequency_hz")])
def test_shaper_refuses_what_it_cannot_cancel(frequencies, zetas, field):
    with pytest.raises(InputError) as err:
        shaper_for("zvd", frequencies, zetas, "pipeline.law.shaper")
    assert err.value.field in (f"pipeline.law.shaper.{field}", f"pipeline.law.shaper.{field}[0]")
