"""Rest-to-rest angle profiles: s(τ) from 0 to 1 over τ = t/T in [0, 1], at rest at both ends.

- `cubic`: s = 3τ² - 2τ³ (SEEDS §004 eq. 13 at rest): the acceleration steps at both ends.
- `versine` (cycloidal): the rate is a versine, s' = 1 - cos 2πτ, so s = τ - sin(2πτ)/(2π) and
  s'' = 2π sin 2πτ: the acceleration starts and ends at zero; its spectrum is zero at f = k/T, k ≥ 2.
- `s_curve` (jerk-limited): the jerk is ±J over four ramps of τ_j = jerk_fraction / 4 each,
  with constant acceleration between ramps and a coast of coast_fraction at constant rate:
  +J, 0, -J, coast, -J, 0, +J. The acceleration is a rectangular pulse pair smoothed by a box of
  width τ_j, so its spectrum carries the factor sinc(f T τ_j): zero at f = k/(T τ_j).

A shaper (testbed.shaping) convolves the profile with its impulses: g(t) = Σ A_i s((t - t_i)/T),
at rest from t_n + T on. `residual_vibration` gives what a profile leaves ringing in a mode.
Derivations: docs/theory/slew-and-settle.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.shaping.shapers import Shaper

PROFILES = ("cubic", "versine", "s_curve")
NO_SHAPER = Shaper(np.ones(1), np.zeros(1))


def s_curve_jerk(jerk_fraction: float, coast_fraction: float) -> tuple[np.ndarray, np.ndarray]:
    """(edges (m + 1,), jerk signs (m,)) of the s-curve's constant-jerk segments over τ in [0, 1],
    zero-length segments left out (no constant-acceleration or coast phase)."""
    tj = jerk_fraction / 4.0
    ta = (1.0 - jerk_fraction - coast_fraction) / 2.0
    lengths = np.array([tj, ta, tj, coast_fraction, tj, ta, tj])
    signs = np.array([1.0, 0.0, -1.0, 0.0, -1.0, 0.0, 1.0])
    keep = lengths > 0
    edges = np.concatenate([[0.0], np.cumsum(lengths[keep])])
    edges[-1] = 1.0
    return edges, signs[keep]


@dataclass(frozen=True)
class RestToRestProfile:
    """The angle fraction g(t) of a rest-to-rest slew of duration T [s], shaped by `shaper`."""

    kind: str
    duration: float
    shaper: Shaper = NO_SHAPER
    jerk_fraction: float = 0.5
    coast_fraction: float = 0.0

    def __post_init__(self):
        if self.kind == "s_curve":
            from scipy.interpolate import PPoly  # here: every run imports this module, few fly an s-curve

            edges, signs = s_curve_jerk(self.jerk_fraction, self.coast_fraction)
            position = PPoly(signs[None, :], edges).antiderivative(3)
            scale = float(position(1.0))
            object.__setattr__(self, "_s", PPoly(position.c / scale, position.x))

    @property
    def end(self) -> float:
        """When the (shaped) profile comes to rest at g = 1 [s]: T + t_n."""
        return self.duration + self.shaper.duration

    def shape(self, tau: float) -> tuple[float, float, float]:
        """(s, ds/dτ, d²s/dτ²) at τ, at rest outside [0, 1] (the ends themselves take the inside's
        acceleration, as the cubic program does: SEEDS §004 eq. 11 on the closed interval)."""
        if tau < 0.0:
            return 0.0, 0.0, 0.0
        if tau > 1.0:
            return 1.0, 0.0, 0.0
        if self.kind == "cubic":
            return tau * tau * (3.0 - 2.0 * tau), 6.0 * tau * (1.0 - tau), 6.0 - 12.0 * tau
        if self.kind == "versine":
            x = 2.0 * np.pi * tau
            return tau - np.sin(x) / (2.0 * np.pi), 1.0 - np.cos(x), 2.0 * np.pi * np.sin(x)
        s = self.__dict__["_s"]
        return float(s(tau)), float(s(tau, 1)), float(s(tau, 2))

    def __call__(self, t: float) -> tuple[float, float, float]:
        """(g, g' [1/s], g'' [1/s²]) at t [s]: Σ A_i s((t - t_i)/T) and its time derivatives."""
        T = self.duration
        g = dg = ddg = 0.0
        for a, ti in zip(self.shaper.amplitudes, self.shaper.times):
            s, ds, dds = self.shape((t - ti) / T)
            g, dg, ddg = g + a * s, dg + a * ds / T, ddg + a * dds / T**2
        return g, dg, ddg


def residual_vibration(profile: RestToRestProfile, frequency_rad_s: float, damping_ratio: float) -> float:
    """The amplitude a mode (ω [rad/s], ζ < 1) of any linear system driven by the profile is left
    ringing with at the profile's end E, relative to what an instantaneous step of the same size
    leaves: the profile is a train of steps g'(τ) dτ, each leaving e^{λ(t - τ)} (λ = -ζω + iω_d),
    so the ratio is |∫₀^E g'(τ) e^{λ(E - τ)} dτ| (for a shaped profile, V(ω, ζ) of the shaper times
    the unshaped profile's own). Integrated by SciPy's quad between the profile's corners."""
    from scipy.integrate import quad  # here: only a study asks for it

    lam = complex(-damping_ratio * frequency_rad_s, frequency_rad_s * np.sqrt(1.0 - damping_ratio**2))
    end = profile.end
    corners = sorted({float(t) for ti in profile.shaper.times for t in (ti, ti + profile.duration)})
    if profile.kind == "s_curve":
        edges = s_curve_jerk(profile.jerk_fraction, profile.coast_fraction)[0]
        corners = sorted(set(corners) | {float(ti + e * profile.duration) for ti in profile.shaper.times
                                         for e in edges})
    total = 0j
    for a, b in zip(corners[:-1], corners[1:]):
        for part, take in ((1.0, np.real), (1j, np.imag)):
            total += part * quad(lambda t: take(profile(t)[1] * np.exp(lam * (end - t))), a, b,
                                 epsabs=1e-13, epsrel=1e-11, limit=200)[0]
    return float(abs(total))
