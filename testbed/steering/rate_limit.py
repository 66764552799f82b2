"""The gimbal-rate limit shared by every law: scale the demand, keep its direction.

Every law here is positively homogeneous in the demand H' (pinv, SR and GSR are linear;
the min-max optimum of k H' is k times the optimum of H'), so the largest k in (0, 1] with
max_i |k beta_rate_i| <= beta_rate_max is k = beta_rate_max / max_i |beta_rate_i|, and
k * beta_rate is exactly the law's answer for the scaled demand k H' (SEEDS §004 eq. (4), (28)).
"""

from __future__ import annotations

import numpy as np


def rate_limit_factor(max_rate: float, beta_rate_max: float) -> float:
    """k = min(1, beta_rate_max / max_rate): the demand scale that meets the limit (eq. 4)."""
    return beta_rate_max / max_rate if max_rate > beta_rate_max else 1.0


def apply_rate_limit(beta_rate: np.ndarray, beta_rate_max: float) -> tuple[np.ndarray, float]:
    """(k * beta_rate, k) with k from rate_limit_factor; never exceeds the limit.

    The clip only removes the last-ulp overshoot that k * max_rate may round to.
    """
    k = rate_limit_factor(float(np.max(np.abs(beta_rate))), beta_rate_max)
    if k == 1.0:
        return beta_rate, 1.0
    return np.clip(beta_rate * k, -beta_rate_max, beta_rate_max), k


def apply_rate_limit_rows(beta_rate: np.ndarray, beta_rate_max: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`apply_rate_limit` on many worlds' rates, a row each: beta_rate (N, n) [rad/s], beta_rate_max
    (N,) [rad/s] -> (k beta_rate (N, n), k (N,)), each row as `apply_rate_limit` gives it."""
    peak = np.max(np.abs(beta_rate), axis=-1)
    limited = peak > beta_rate_max
    k = np.where(limited, beta_rate_max / np.where(limited, peak, 1.0), 1.0)
    bound = beta_rate_max[:, None]
    return np.where(limited[:, None], np.clip(beta_rate * k[:, None], -bound, bound), beta_rate), k


def apply_rate_bounds(beta_rate: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, float]:
    """(p + k (beta_rate - p), k): per-gimbal bounds lo <= beta' <= hi (4,) instead of +-beta_rate_max.

    p is the point of the box nearest zero and k the largest factor in [0, 1] that stays in the
    box. When the box holds zero (no acceleration limit forces a gimbal to keep turning) p = 0
    and this is the demand scaling above: k beta_rate delivers k H' exactly. Otherwise
    (gimbal_limits.py: a gimbal that must brake) the command goes from the slowest allowed
    rates p towards the law's answer as far as the box allows; its torque is then not k H'.
    """
    p = np.clip(0.0, lo, hi)
    step = beta_rate - p
    k = 1.0
    for rate, start, low, high in zip(beta_rate, p, lo, hi):
        if rate > high:
            k = min(k, (high - start) / (rate - start))
        elif rate < low:
            k = min(k, (low - start) / (rate - start))
    if k == 1.0:
        return beta_rate, 1.0
    k += 0.0  # -0.0 (an end of the box at p itself) reads as 0
    return np.clip(p + k * step, lo, hi), k


def apply_rate_bounds_rows(beta_rate: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`apply_rate_bounds` on many worlds' rates, a row each: beta_rate, lo, hi (N, n) [rad/s] ->
    (the bounded rates (N, n), k (N,)), each row as `apply_rate_bounds` gives it."""
    p = np.clip(0.0, lo, hi)
    step = beta_rate - p
    over, under = beta_rate > hi, beta_rate < lo
    ratio = np.where(over, (hi - p) / np.where(over, step, 1.0),
                     np.where(under, (lo - p) / np.where(under, step, 1.0), 1.0))
    k = np.minimum(ratio.min(axis=-1), 1.0) + 0.0  # -0.0 (an end of the box at p itself) reads as 0
    limited = (k < 1.0)[:, None]
    return np.where(limited, np.clip(p + k[:, None] * step, lo, hi), beta_rate), k
