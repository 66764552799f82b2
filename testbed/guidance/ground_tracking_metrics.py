"""Metrics of the `ground_tracking` law, over the samples it flags `law/tracking` 1 (on a
target, settled after its slew, the spacecraft above the minimum elevation): the true pointing
error, the jitter and the time tracked (running reductions: no history is kept)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.math.quaternion import quat_angle, quat_conj, quat_mul, quat_rotate
from testbed.metrics import metric
from testbed.recording.reductions import _OfSignal

ARCSEC_PER_RAD = 180.0 * 3600.0 / np.pi


@dataclass(frozen=True)
class WhileTracking(_OfSignal):
    """Over the rows where signal `key` (the tracking flag) is 1: (the largest angle [rad]
    between the true attitude and the target's, the sum of |ω - R(δq)ᵀ ω*|² [rad²/s²], the
    number of rows, the time [s] they span at the trace period), δq = Λ*~ ∘ q the true attitude
    seen from the target, ω* the target's rate."""

    def update(self, state, chunk):
        names = (self.key, "truth/quat", "law/target_quat", "truth/omega", "law/target_omega")
        if any(name not in chunk.signals for name in names) or len(chunk.time) == 0:
            return state
        flag, q, q_target, omega, omega_target = (chunk.signals[name] for name in names)
        rows = (flag[:, 0] > 0.5) & np.all(np.isfinite(q), axis=1) & np.all(np.isfinite(omega), axis=1)
        peak, squares, count = (0.0, 0.0, 0) if state is None else state
        if np.any(rows):
            error = quat_mul(quat_conj(q_target[rows]), q[rows])
            rate_error = omega[rows] - quat_rotate(quat_conj(error), omega_target[rows])
            peak = max(peak, float(np.max(quat_angle(error))))
            squares += float(np.sum(rate_error * rate_error))
            count += int(np.sum(rows))
        return peak, squares, count


TRACKING = WhileTracking("law/tracking")


def _tracking(scenario) -> bool:
    return scenario.stages["law"][0] == "ground_tracking"


def _tracked(run):
    state = run.reduced(TRACKING)
    return (float("nan"), float("nan"), 0) if state is None or state[2] == 0 else state


@metric("max_target_error_deg", applies=_tracking, uses=(TRACKING,))
def max_target_error_deg(run) -> float:
    """max while tracking a ground target of the angle from the true attitude to the law's target [deg] (NaN: never tracked)."""
    return float(np.degrees(_tracked(run)[0]))


@metric("target_jitter_arcsec_s", applies=_tracking, uses=(TRACKING,))
def target_jitter_arcsec_s(run) -> float:
    """rms while tracking a ground target of |true body rate - target rate| [arcsec/s]: the line of sight's smear rate."""
    _, squares, count = _tracked(run)
    return float(np.sqrt(squares / count) * ARCSEC_PER_RAD) if count else float("nan")


@metric("target_tracked_s", applies=_tracking, uses=(TRACKING,))
def target_tracked_s(run) -> float:
    """the time the ground_tracking law flags law/tracking 1 [s] (trace samples times the trace period)."""
    return _tracked(run)[2] * run.scenario.sim.trace_period_s
