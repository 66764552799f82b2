"""Slew-and-settle figures against signals whose answers are known in closed form: the settling
time of an exponentially decaying error, the peak and the power of the bus-rate spectrum."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from testbed.guidance.settling import rate_spectrum, settling_time, spectral_peak


def test_settling_time_of_a_decaying_cone_is_log_ratio_over_decay_rate():
    """A coning error A e^{-σt} (cos ω_d t, sin ω_d t) has |e| = A e^{-σt}: it reaches bound b at
    t = ln(A/b)/σ exactly; linear interpolation between samples dt apart errs by ~(σ dt)²/8 relative."""
    amplitude, sigma, bound, after, dt = 0.03, 0.21, 1e-4, 12.0, 0.01
    time = np.arange(0.0, 60.0, dt)
    cone = amplitude * np.exp(-sigma * (time - after))[:, None] * np.column_stack([np.cos(2.1 * time),
                                                                                  np.sin(2.1 * time)])
    error = np.where(time >= after, np.linalg.norm(cone, axis=1), 1.0)
    expected = np.log(amplitude / bound) / sigma
    assert settling_time(time, error, bound, after) == pytest.approx(expected, rel=(sigma * dt) ** 2)


def test_settling_time_of_a_decaying_sinusoid_is_its_last_crossing():
    """x = A e^{-ζωt} cos ω_d t: |x| last leaves the bound on the peak before the envelope's
    crossing ln(A/b)/(ζω); that crossing is found by Brent's method on the signal itself."""
    amplitude, zeta, w, bound, dt = 1.0, 0.03, 2 * np.pi * 0.45, 0.05, 0.002
    wd, sigma = w * np.sqrt(1 - zeta**2), zeta * w
    time = np.arange(0.0, 80.0, dt)
    x = amplitude * np.exp(-sigma * time) * np.cos(wd * time)
    envelope_crossing = np.log(amplitude / bound) / sigma
    peaks = np.arange(0, envelope_crossing * wd / np.pi + 1) * np.pi / wd  # the peaks of |cos|
    last_peak = peaks[np.abs(amplitude * np.exp(-sigma * peaks) * np.cos(wd * peaks)) > bound][-1]
    expected = brentq(lambda t: abs(amplitude * np.exp(-sigma * t) * np.cos(wd * t)) - bound, last_peak,
                      last_peak + np.pi / (2 * wd))
    assert settling_time(time, np.abs(x), bound, 0.0) == pytest.approx(expected, abs=1e-5)  # (ω dt)² A/slope
    assert envelope_crossing - np.pi / wd < expected <= envelope_crossing


def test_settling_time_edges():
    time = np.linspace(0.0, 10.0, 101)
    assert settling_time(time, np.full(101, 1e-9), 1e-6, 2.0) == 0.0  # already within: settled at the end
    with pytest.raises(ValueError, match="still exceeds"):
        settling_time(time, np.linspace(1.0, 0.5, 101), 0.1, 2.0)
    with pytest.raises(ValueError, match="ends before"):
        settling_time(time, np.zeros(101), 0.1, 11.0)


def test_rate_spectrum_peaks_at_the_mode_and_holds_its_power():
    """A decaying rate oscillation at f0 = 0.613 Hz on two axes, plus white noise of known
    variance: the PSD's refined peak lies within a fifth of a bin (2/window) of f0 (a Gaussian
    through the Hann window's main lobe), and ∫S df of a steady sinusoid of amplitude a is a²/2
    (Parseval; 2 % for the Hann window's leakage)."""
    rng = np.random.default_rng(7)
    f0, dt, after = 0.613, 0.02, 20.0
    time = np.arange(0.0, 140.0, dt)
    decay = np.exp(-0.02 * np.maximum(time - after, 0.0))
    omega = np.column_stack([1e-3 * decay * np.sin(2 * np.pi * f0 * time), 4e-4 * decay * np.cos(2 * np.pi * f0 * time),
                             1e-6 * rng.standard_normal(len(time))])
    f, psd = rate_spectrum(time, omega, after)
    assert abs(spectral_peak(f, psd) - f0) <= 0.2 * f[1]
    assert f[1] == pytest.approx(2.0 / 120.0, rel=1e-3)  # segments of half the 120 s window
    steady = np.column_stack([2e-3 * np.sin(2 * np.pi * f0 * time), np.zeros(len(time)), np.zeros(len(time))])
    f, psd = rate_spectrum(time, steady, after)
    assert np.sum(psd) * f[1] == pytest.approx((2e-3) ** 2 / 2, rel=0.02)


@pytest.mark.slow
def test_the_trace_holds_the_spectrum_of_its_own_rates(tmp_path):
    """agile_slew_flexible cut at 50 s: `spectrum/bus_rate_psd` in the .rrd is Welch's PSD of the
    trace's own truth/omega after the slew's end (stored as doubles), its peak the
    run's jitter_peak_hz; a slew without settle_rate_deg_s writes no spectrum."""
    from pathlib import Path

    from testbed.recording.trace_reader import _chunks, read_rrd
    from testbed.runner import run_scenario
    from testbed.scenario.loading import load_scenario

    out = tmp_path / "flex.rrd"
    result = run_scenario(load_scenario("agile_slew_flexible", ["sim.duration_s=50"]), out)
    assert result.status == "ok"
    info = read_rrd(Path(out), signals=True)
    time, omega = info["trace"]["truth/omega"]
    f, psd = rate_spectrum(time, omega, 32.0)  # the program ends at start_s + duration_s = 2 + 30 s
    stored = [c.to_record_batch() for c in _chunks(Path(out)) if str(c.entity_path) == "/spectrum/bus_rate_psd"]
    batch = stored[-1]
    values, abscissa = (batch.column(f"BarChart:{part}").to_pylist()[0][0]["buffer"] for part in ("values", "abscissa"))
    assert np.allclose(values, psd, rtol=1e-12) and np.allclose(abscissa, f, rtol=1e-12)
    assert result.metrics["jitter_peak_hz"] == pytest.approx(spectral_peak(f, psd), rel=1e-6)
    plain = tmp_path / "plain.rrd"
    run_scenario(load_scenario("reorient_pinv", ["sim.duration_s=2"]), plain)
    assert not any("spectrum" in entity for entity in read_rrd(Path(plain))["entities"])
