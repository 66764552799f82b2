"""Metrics of the program-motion runs (seed 002), computed from the recorded truth.

The deviations x = q - r(t) and x' of the Euler angles (truth/deviation,
truth/deviation_rate, the paper's Figs. 2-7) at the end of the run, and a monotone-envelope
ratio: the peak of |x| over each ENVELOPE_WINDOW_S window divided by the peak over the
window before, the largest such ratio (< 1: every window's peak is below the previous one's),
kept as the run goes (testbed.recording.reductions.WindowPeakRatio).
"""

from __future__ import annotations

from testbed.metrics import final_norm_metric, metric
from testbed.recording.reductions import WindowPeakRatio

ENVELOPE_WINDOW_S = 5.0


def _program(scenario) -> bool:
    return scenario.system == "gyrostat_variable"


final_norm_metric("final_deviation_rad", "truth/deviation",
                  "|x(T)|, x = q - r(t) the Euler-angle deviation from the program at the end [rad].", _program)
final_norm_metric("final_deviation_rate_rad_s", "truth/deviation_rate", "|x'(T)| at the end of the run [rad/s].",
                  _program)


DEVIATION_ENVELOPE = WindowPeakRatio("truth/deviation", ENVELOPE_WINDOW_S)
DEVIATION_RATE_ENVELOPE = WindowPeakRatio("truth/deviation_rate", ENVELOPE_WINDOW_S)


@metric("deviation_envelope_ratio", applies=_program, uses=(DEVIATION_ENVELOPE,))
def deviation_envelope_ratio(run) -> float:
    """max over consecutive 5 s windows of peak|x| / previous window's peak|x| (< 1: decaying envelope)."""
    return run.reduced(DEVIATION_ENVELOPE)


@metric("deviation_rate_envelope_ratio", applies=_program, uses=(DEVIATION_RATE_ENVELOPE,))
def deviation_rate_envelope_ratio(run) -> float:
    """max over consecutive 5 s windows of peak|x'| / previous window's peak|x'|."""
    return run.reduced(DEVIATION_RATE_ENVELOPE)
