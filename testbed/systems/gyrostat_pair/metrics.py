"""Metrics of the leader/follower runs (seed 003), computed from the recorded truth.

Observer: the estimation error of the leader's w3 (estimator/omega - truth/omega; it
equals -eta of eq. 14, exactly exponential at gamma). Synchronisation: the error p - w.
Their final size and the decay rate fitted to them.
"""

from __future__ import annotations

import numpy as np

from testbed.metrics import final_norm_metric, metric, sample_norms

FIT_FLOOR_REL = 1e-4   # fit the decay down to this fraction of the peak


def fitted_decay_rate(t: np.ndarray, error: np.ndarray, floor_rel: float = FIT_FLOOR_REL) -> float:
    """-slope of the least-squares line through log|error| from its peak on, while
    |error| >= floor_rel * peak (the first contiguous stretch) [1/s]."""
    error = np.abs(error)
    start = int(np.nanargmax(error))
    below = np.nonzero(error[start:] < floor_rel * error[start])[0]
    stop = start + (below[0] if len(below) else len(error) - start)
    if stop - start < 3:
        return float("nan")
    return float(-np.polyfit(t[start:stop], np.log(error[start:stop]), 1)[0])


# --- seed 003: observer ----------------------------------------------------------------------

def _observer(scenario) -> bool:
    return scenario.system == "gyrostat_pair" and scenario.stages["estimator"][0] == "invariant_manifold"


# the decay fits read the history from the error's peak on (kept: these signals only)
OBSERVER_SIGNALS = ("estimator/omega", "truth/omega")


def _w3_error(run) -> np.ndarray:
    return run.recorder["estimator/omega"][:, 2] - run.recorder["truth/omega"][:, 2]


def _valid(run):
    """Samples where the estimator ran (the final row holds the truth only)."""
    return np.isfinite(run.recorder["estimator/omega"][:, 0])


@metric("observer_decay_rate_1_s", applies=_observer, uses=OBSERVER_SIGNALS)
def observer_decay_rate_1_s(run) -> float:
    """Decay rate fitted to |w3_estimate - w3| (eq. 14: eta' = -gamma eta) [1/s]."""
    ok = _valid(run)
    return fitted_decay_rate(run.recorder.time[ok], _w3_error(run)[ok])


@metric("observer_decay_rate_error_rel", applies=_observer, uses=OBSERVER_SIGNALS)
def observer_decay_rate_error_rel(run) -> float:
    """|fitted decay rate - gamma| / gamma."""
    gamma = run.scenario.stages["estimator"][1].gamma_1_s
    return abs(observer_decay_rate_1_s(run) - gamma) / gamma


@metric("observer_final_error_rad_s", applies=_observer, uses=OBSERVER_SIGNALS)
def observer_final_error_rad_s(run) -> float:
    """|w_estimate - w| (all three components) at the last estimate [rad/s]."""
    ok = _valid(run)
    error = run.recorder["estimator/omega"][ok] - run.recorder["truth/omega"][ok]
    return float(np.linalg.norm(error[-1]))


# --- seed 003: synchronisation ---------------------------------------------------------------

def _sync(scenario) -> bool:
    return scenario.system == "gyrostat_pair" and scenario.stages["law"][0] == "synchronisation"


final_norm_metric("sync_final_error_rad_s", "truth/sync_error",
                  "|p - w|, follower minus leader angular velocity, at the end [rad/s].", _sync)


@metric("sync_decay_rate_1_s", applies=_sync, uses=("truth/sync_error",))
def sync_decay_rate_1_s(run) -> float:
    """Decay rate fitted to |p - w| from its peak down to 1e-4 of it [1/s]."""
    return fitted_decay_rate(run.recorder.time, sample_norms(run, "truth/sync_error"))
