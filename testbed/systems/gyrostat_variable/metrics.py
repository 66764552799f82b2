"""Metrics of the program-motion runs (seed 002), computed from the recorded truth.

The deviations x = q - r(t) and x' of the Euler angles (truth/deviation,
truth/deviation_rate, the paper's Figs. 2-7) at the end of the run, and a monotone-envelope
ratio: the peak of |x| over each ENVELOPE_WINDOW_S window divided by the peak over the
window before, the largest such ratio (< 1: every window's peak is below the previous one's).
"""

from __future__ import annotations

import numpy as np

from testbed.metrics import final_norm_metric, metric, sample_norms

ENVELOPE_WINDOW_S = 5.0


def envelope_ratio(t: np.ndarray, values: np.ndarray, window: float = ENVELOPE_WINDOW_S) -> float:
    """max_k peak_{k+1} / peak_k of |values| over consecutive windows [k W, (k+1) W)."""
    index = np.floor((t - t[0]) / window + 1e-9).astype(int)
    peaks = np.array([np.max(values[index == k]) for k in range(index.max() + 1) if np.any(index == k)])
    if len(peaks) < 2:
        return float("nan")
    return float(np.max(peaks[1:] / peaks[:-1]))


def _program(scenario) -> bool:
    return scenario.system == "gyrostat_variable"


final_norm_metric("final_deviation_rad", "truth/deviation",
                  "|x(T)|, x = q - r(t) the Euler-angle deviation from the program at the end [rad].", _program)
final_norm_metric("final_deviation_rate_rad_s", "truth/deviation_rate", "|x'(T)| at the end of the run [rad/s].",
                  _program)


@metric("deviation_envelope_ratio", applies=_program)
def deviation_envelope_ratio(run) -> float:
    """max over consecutive 5 s windows of peak|x| / previous window's peak|x| (< 1: decaying envelope)."""
    return envelope_ratio(run.recorder.time, sample_norms(run, "truth/deviation"))


@metric("deviation_rate_envelope_ratio", applies=_program)
def deviation_rate_envelope_ratio(run) -> float:
    """max over consecutive 5 s windows of peak|x'| / previous window's peak|x'|."""
    return envelope_ratio(run.recorder.time, sample_norms(run, "truth/deviation_rate"))
