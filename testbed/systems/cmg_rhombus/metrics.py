"""Metrics of the CMG spacecraft's actuators (the steering metrics live with the steering stages)."""

from __future__ import annotations

import numpy as np

from testbed.metrics import metric
from testbed.pipeline import output_of


def _servo_commanded(scenario) -> bool:
    """The allocator commands gimbal rates (not only ideal torques, not nothing)."""
    return scenario.system == "cmg_rhombus" and output_of("allocator", scenario.stages["allocator"][0]) == "gimbal_rates"


@metric("gimbal_rate_error_rel", applies=_servo_commanded)
def gimbal_rate_error_rel(run) -> float:
    """max_i max_t |b'_i(t_k+1) - cmd_i(t_k)| / max_t |cmd_i|: servo tracking of the held command, after 0.1 s."""
    # each trace sample holds the rate b'(t_k+1) and the command held over (t_k, t_k+1]
    # (truth/gimbal_rate_command), so any trace period measures the end of a hold
    rates = run.recorder["truth/gimbal_rate"]
    command = run.recorder["truth/gimbal_rate_command"]
    keep = run.recorder.time > 0.1
    scale = np.maximum(np.nanmax(np.abs(command), axis=0), 1e-12)
    return float(np.nanmax(np.abs(rates[keep] - command[keep]) / scale))
