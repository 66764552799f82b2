"""How a slew settles: settling time of an error to a bound after the slew's end, and the
spectrum of the bus rate over the window after it (docs/theory/slew-and-settle.md)."""

from __future__ import annotations

import numpy as np

# Welch's segments span half the window (50 % overlap: three segments averaged), so that the
# frequency resolution is 2 / window while the estimate still averages.
SEGMENTS_PER_WINDOW = 2
MIN_SAMPLES = 16


def settling_time(time, error, bound: float, after: float) -> float:
    """Time [s] from `after` [s] until the non-negative `error` (per sample at `time` [s]) drops
    to `bound` for the last time and stays at or under it to the record's end; 0 if it never
    exceeds the bound from `after` on. The crossing is interpolated linearly between the last
    sample above the bound and the next. Raises ValueError if the error still exceeds the bound
    at the last sample, or no sample lies at or after `after`."""
    time, error = np.asarray(time, float), np.asarray(error, float)
    window = time >= after
    if not np.any(window):
        raise ValueError(f"the run ends before the slew's end at {after:g} s")
    t, e = time[window], error[window]
    above = np.flatnonzero(~(e <= bound))  # a NaN counts as not settled
    if not len(above):
        return 0.0
    k = above[-1]
    if k == len(e) - 1:
        raise ValueError(f"the error {e[-1]:.3g} still exceeds the bound {bound:g} at the run's end")
    crossing = t[k] + (e[k] - bound) / (e[k] - e[k + 1]) * (t[k + 1] - t[k])
    return float(max(crossing, after) - after)


def rate_spectrum(time, omega, after: float) -> tuple[np.ndarray, np.ndarray]:
    """(f [Hz], S [(rad/s)²/Hz]): the one-sided power spectral density of the bus rate vector
    (the sum of its three axes' PSDs) over the samples from `after` [s] on, by Welch's method
    (Hann window, segments of half the window, each segment's mean removed). The samples are
    taken on a uniform grid of the median trace step (linear interpolation: the run's final
    sample may lie off the grid)."""
    time, omega = np.asarray(time, float), np.asarray(omega, float).reshape(len(time), -1)
    t = time[time >= after]
    if len(t) < MIN_SAMPLES:
        raise ValueError(f"{len(t)} trace samples after the slew's end at {after:g} s; the spectrum needs "
                         f"at least {MIN_SAMPLES}")
    from scipy.signal import welch  # here: importing scipy.signal costs a run that asks for no spectrum ~0.5 s

    step = float(np.median(np.diff(t)))
    grid = t[0] + step * np.arange(int(np.floor((t[-1] - t[0]) / step + 1e-9)) + 1)
    samples = np.column_stack([np.interp(grid, time, omega[:, j]) for j in range(omega.shape[1])])
    f, psd = welch(samples, fs=1.0 / step, window="hann", nperseg=len(grid) // SEGMENTS_PER_WINDOW, axis=0)
    return f, psd.sum(axis=1)


def spectral_peak(f, psd) -> float:
    """The frequency [Hz] of the largest PSD value above 0 Hz, refined by the parabola through
    the logarithms of it and its two neighbours (a Gaussian fitted to the peak: a Hann window's
    main lobe is close to one, so the estimate lands within a small fraction of a bin)."""
    k = 1 + int(np.argmax(psd[1:]))
    if k == len(f) - 1:
        return float(f[k])
    low, mid, high = np.log(np.maximum(psd[k - 1:k + 2], np.finfo(float).tiny))
    curvature = low - 2.0 * mid + high
    shift = 0.5 * (low - high) / curvature if curvature < 0 else 0.0
    return float(f[k] + shift * (f[1] - f[0]))
