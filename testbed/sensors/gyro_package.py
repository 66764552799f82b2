"""Three-axis gyro package: Farrenkopf's continuous model, sampled exactly.

Continuous model (Farrenkopf 1978, "Analytic steady-state accuracy solutions for two common
spacecraft attitude estimators", eq. 1-2):  ω̃ = (I + S) ω + β + η_v,  β' = η_u, with η_v, η_u
white of densities σ_v² (angle random walk) and σ_u² (rate random walk). The package reports
the mean rate over each sample interval Δt (an angle increment over Δt). Given β_k, the pair
(∫ ω̃ dt, β_{k+1}) is Gaussian, and drawing

    β_{k+1} = β_k + σ_u Δt^½ N_u
    ω̃_k     = (I + S) θ_k / Δt + ½ (β_k + β_{k+1}) + (σ_v² / Δt + σ_u² Δt / 12)^½ N_v

gives it exactly (the gyro simulation model of Crassidis & Junkins, "Optimal Estimation of
Dynamic Systems", 2nd ed., ch. 7; the Δt/12 term is the Brownian bridge of β inside the interval):
the angle error over Δt has variance σ_v² Δt + σ_u² Δt³ / 3 and covariance -σ_u² Δt² / 2 with
the bias step, what the MEKF's process noise assumes. θ_k is the true rotation vector over the
interval (from the bus attitudes at its ends), S the scale factors on the diagonal and the
misalignments off it. Quantisation rounds each angle increment to the output step, carrying the
remainder to the next sample (an integrating gyro loses no angle).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.errors import InputError
from testbed.scenario.schema import join, param
from testbed.stages.white_noise import WhiteNoise

ZERO3 = [0.0, 0.0, 0.0]
ZERO6 = [0.0] * 6
# the order of `misalignment_rad`: the off-diagonal entries (row, column) of S
OFF_DIAGONAL = ((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1))
# The noise densities and errors are bounded where the package's and the filter's squares and
# products stay normal doubles (docs/theory/attitude_determination.md "Gyro package"): an ARW of
# 1e200 overflows its square, a quantum of 1e-320 its quotient angle / step. A quantum below this
# is far finer than any gyro's and is refused, not rounded to.
SMALLEST_QUANTUM_RAD = 1e-12


@dataclass(kw_only=True)
class GyroPackageParams:
    angle_random_walk_rad_sqrt_s: float = param(ge=1e-15, le=1.0, doc="sigma_v: white rate noise density (ARW)")
    rate_random_walk_rad_s_sqrt_s: float = param(ge=1e-18, le=1.0, doc="sigma_u: bias random walk density (RRW)")
    initial_bias_rad_s: list[float] = param(ZERO3, length=3, ge=-1.0, le=1.0, doc="bias at t = 0, package axes = body axes")
    scale_factor_ppm: list[float] = param(ZERO3, length=3, ge=-1e6, le=1e6, doc="scale-factor error per axis (diagonal of S)")
    misalignment_rad: list[float] = param(ZERO6, length=6, ge=-1.0, le=1.0, doc="off-diagonal of S: xy, xz, yx, yz, zx, zy")
    quantisation_rad: float = param(0.0, ge=0, le=1.0, doc="angle-increment step of the output (0: none, else "
                                    f"at least {SMALLEST_QUANTUM_RAD:g})")
    sample_period_s: float | None = param(None, gt=0, doc="default: the sensor period (sim.estimator_period_s)")
    seed: int = param(0, ge=0, doc="noise seed: the same seed gives the same samples bit for bit")

    def validate(self, path: str) -> None:
        if 0 < self.quantisation_rad < SMALLEST_QUANTUM_RAD:
            raise InputError(join(path, "quantisation_rad"), f"must be 0 (no quantisation) or at least "
                             f"{SMALLEST_QUANTUM_RAD:g} rad, got {self.quantisation_rad:g}")


def sensing_matrix(params: GyroPackageParams) -> np.ndarray:
    """I + S: scale factors on the diagonal, misalignments off it."""
    matrix = np.eye(3) + np.diag(np.asarray(params.scale_factor_ppm, float) * 1e-6)
    for (row, column), value in zip(OFF_DIAGONAL, params.misalignment_rad):
        matrix[row, column] += value
    return matrix


def mean_rate(matrix, rotation, period, bias, bias_step, white) -> tuple[np.ndarray, np.ndarray]:
    """(ω̃_k, β_{k+1}) of the module doc, unquantised, for the draws `bias_step`, `white` [rad/s];
    on (..., 3) rows of packages (matrix (..., 3, 3), period a number or (..., 1))."""
    following = bias + bias_step
    return np.matvec(matrix, rotation) / period + 0.5 * (bias + following) + white, following


class GyroPackage:
    """The error model of the module doc, one sample at a time."""

    def __init__(self, params: GyroPackageParams, period: float):
        self.period = period
        self.arw, self.rrw = params.angle_random_walk_rad_sqrt_s, params.rate_random_walk_rad_s_sqrt_s
        self.white = float(np.sqrt(self.arw**2 / period + self.rrw**2 * period / 12.0))
        self.bias = np.array(params.initial_bias_rad_s, float)
        self.matrix = sensing_matrix(params)
        self.step = params.quantisation_rad
        self.remainder = np.zeros(3)
        self.noise = WhiteNoise(params.seed)

    def draws(self) -> tuple[np.ndarray, np.ndarray]:
        """The next sample's bias step σ_u Δt^½ N_u and white noise of the mean rate, drawn in
        that order from the package's own generator [rad/s]."""
        return self.noise.add(0.0, self.rrw * np.sqrt(self.period), 3), self.noise.add(0.0, self.white, 3)

    def sample(self, rotation: np.ndarray) -> np.ndarray:
        """The mean rate the package reports over an interval in which the body turned by the
        rotation vector `rotation` [rad, body axes]; advances the bias by one interval [rad/s]."""
        rate, self.bias = mean_rate(self.matrix, rotation, self.period, self.bias, *self.draws())
        if self.step:
            angle = rate * self.period + self.remainder
            counted = self.step * np.round(angle / self.step)
            self.remainder = angle - counted
            rate = counted / self.period
        return rate
