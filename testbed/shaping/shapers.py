"""ZV and ZVD input shapers and their residual-vibration sensitivity (Singer & Seering 1990).

A shaper is a sequence of impulses (amplitudes A_i summing to 1, times t_i from 0) convolved with
a command: the shaped command u_s(t) = Σ A_i u(t - t_i) reaches the same end state, t_n later.
For a mode of natural frequency ω [rad/s] and damping ratio ζ < 1, with ω_d = ω √(1 - ζ²) and
K = exp(-ζπ / √(1 - ζ²)):

    ZV:  A = (1, K) / (1 + K),               t = (0, π/ω_d)
    ZVD: A = (1, 2K, K²) / (1 + K)²,         t = (0, π/ω_d, 2π/ω_d)

The residual vibration when the shaped command ends (t_n after the unshaped one), relative to
that of the unshaped command when it ends, is (Singer & Seering 1990, eq. 4; the sensitivity curve)

    V(ω, ζ) = exp(-ζ ω t_n) √[(Σ A_i e^{ζωt_i} cos ω_d t_i)² + (Σ A_i e^{ζωt_i} sin ω_d t_i)²].

Shapers for several modes are convolved (each mode's shaper applied in turn).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.errors import InputError


@dataclass(frozen=True)
class Shaper:
    """Impulse amplitudes (sum 1) and their times [s], first time 0, increasing."""

    amplitudes: np.ndarray
    times: np.ndarray

    @property
    def duration(self) -> float:
        """t_n, the time the shaper adds to a command [s]."""
        return float(self.times[-1])

    def then(self, other: "Shaper") -> "Shaper":
        """This shaper convolved with `other` (both modes cancelled), equal times merged."""
        times = (self.times[:, None] + other.times[None, :]).ravel()
        amplitudes = (self.amplitudes[:, None] * other.amplitudes[None, :]).ravel()
        merged, index = np.unique(np.round(times, 12), return_inverse=True)
        return Shaper(np.bincount(index, weights=amplitudes), merged)


def _damped(frequency_rad_s: float, damping_ratio: float, path: str, index: str = "") -> tuple[float, float]:
    """(ω_d [rad/s], K) of a mode, refusing what no shaper of this kind can cancel; errors name
    `path`.frequency_hz`index` and `path`.damping_ratio`index`."""
    if not np.isfinite(frequency_rad_s) or frequency_rad_s <= 0:
        raise InputError(f"{path}.frequency_hz{index}",
                         f"must be a finite number > 0, got {frequency_rad_s / (2 * np.pi):g}")
    if not 0.0 <= damping_ratio < 1.0:
        raise InputError(f"{path}.damping_ratio{index}",
                         f"must lie in [0, 1) (an oscillating mode), got {damping_ratio:g}")
    root = np.sqrt(1.0 - damping_ratio**2)
    return frequency_rad_s * root, float(np.exp(-damping_ratio * np.pi / root))


def zv(frequency_rad_s: float, damping_ratio: float, path: str = "shaper", index: str = "") -> Shaper:
    """The zero-vibration shaper of one mode: two impulses half a damped period apart."""
    wd, k = _damped(frequency_rad_s, damping_ratio, path, index)
    return Shaper(np.array([1.0, k]) / (1.0 + k), np.array([0.0, np.pi / wd]))


def zvd(frequency_rad_s: float, damping_ratio: float, path: str = "shaper", index: str = "") -> Shaper:
    """The zero-vibration-and-derivative shaper of one mode: three impulses over one damped period."""
    wd, k = _damped(frequency_rad_s, damping_ratio, path, index)
    return Shaper(np.array([1.0, 2.0 * k, k * k]) / (1.0 + k) ** 2, np.array([0.0, np.pi / wd, 2.0 * np.pi / wd]))


KINDS = {"zv": zv, "zvd": zvd}
# Each mode multiplies the impulses (2 for ZV, 3 for ZVD), and a shaped command sums a term per
# impulse at every control tick: 4 ZVD modes make 81.
MAX_MODES = 4


def shaper_for(kind: str, frequencies_hz, damping_ratios, path: str = "shaper") -> Shaper:
    """The `kind` shaper ("zv" or "zvd") of every mode (frequency [Hz], damping ratio), convolved."""
    if len(frequencies_hz) != len(damping_ratios) or not len(frequencies_hz):
        raise InputError(f"{path}.damping_ratio", "give one damping ratio per mode frequency, at least one mode")
    if len(frequencies_hz) > MAX_MODES:
        raise InputError(f"{path}.frequency_hz", f"at most {MAX_MODES} modes (each multiplies the impulses), "
                         f"got {len(frequencies_hz)}")
    shaper = Shaper(np.ones(1), np.zeros(1))
    for i, (f, z) in enumerate(zip(frequencies_hz, damping_ratios)):
        shaper = shaper.then(KINDS[kind](2.0 * np.pi * float(f), float(z), path, f"[{i}]"))
    return shaper


def residual_vibration(shaper: Shaper, frequency_rad_s, damping_ratio: float) -> np.ndarray:
    """V(ω, ζ): the shaped command's residual vibration of the mode (ω [rad/s], ζ < 1) over the
    unshaped command's (Singer & Seering 1990, eq. 4); ω may be an array (the sensitivity curve)."""
    w = np.asarray(frequency_rad_s, float)[..., None]
    wd = w * np.sqrt(1.0 - damping_ratio**2)
    grow = shaper.amplitudes * np.exp(damping_ratio * w * shaper.times)
    c = (grow * np.cos(wd * shaper.times)).sum(axis=-1)
    s = (grow * np.sin(wd * shaper.times)).sum(axis=-1)
    return np.exp(-damping_ratio * w[..., 0] * shaper.duration) * np.hypot(c, s)
