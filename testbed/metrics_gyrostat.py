"""Metrics of the gyrostat scenarios (seeds 002 and 003), computed from the recorded truth.

Program motion (gyrostat_variable): the deviations x = q - r(t) and x' of the Euler angles
(truth/deviation, truth/deviation_rate, the paper's Figs. 2-7) at the end of the run, and a
monotone-envelope ratio: the peak of |x| over each ENVELOPE_WINDOW_S window divided by the
peak over the window before, the largest such ratio (< 1: every window's peak is below the
previous one's).

Observer and synchronisation (gyrostat_pair): the estimation error of the leader's w3
(estimator/omega - truth/omega; it equals -eta of eq. 14, exactly exponential at gamma) and
the synchronisation error p - w, their final size and the decay rate fitted to them.
"""

from __future__ import annotations

import numpy as np

from testbed.metrics import metric

ENVELOPE_WINDOW_S = 5.0
FIT_FLOOR_REL = 1e-4   # fit the decay down to this fraction of the peak


def envelope_ratio(t: np.ndarray, values: np.ndarray, window: float = ENVELOPE_WINDOW_S) -> float:
    """max_k peak_{k+1} / peak_k of |values| over consecutive windows [k W, (k+1) W)."""
    index = np.floor((t - t[0]) / window + 1e-9).astype(int)
    peaks = np.array([np.max(values[index == k]) for k in range(index.max() + 1) if np.any(index == k)])
    if len(peaks) < 2:
        return float("nan")
    return float(np.max(peaks[1:] / peaks[:-1]))


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


# --- seed 002: program motion ---------------------------------------------------------------

def _program(scenario) -> bool:
    return scenario.system == "gyrostat_variable"


def _norms(run, key):
    return np.linalg.norm(run.recorder[key], axis=1)


@metric("final_deviation_rad", applies=_program)
def final_deviation_rad(run) -> float:
    """|x(T)|, x = q - r(t) the Euler-angle deviation from the program at the end [rad]."""
    return float(_norms(run, "truth/deviation")[-1])


@metric("final_deviation_rate_rad_s", applies=_program)
def final_deviation_rate_rad_s(run) -> float:
    """|x'(T)| at the end of the run [rad/s]."""
    return float(_norms(run, "truth/deviation_rate")[-1])


@metric("deviation_envelope_ratio", applies=_program)
def deviation_envelope_ratio(run) -> float:
    """max over consecutive 5 s windows of peak|x| / previous window's peak|x| (< 1: decaying envelope)."""
    return envelope_ratio(run.recorder.time, _norms(run, "truth/deviation"))


@metric("deviation_rate_envelope_ratio", applies=_program)
def deviation_rate_envelope_ratio(run) -> float:
    """max over consecutive 5 s windows of peak|x'| / previous window's peak|x'|."""
    return envelope_ratio(run.recorder.time, _norms(run, "truth/deviation_rate"))


# --- seed 003: observer ----------------------------------------------------------------------

def _observer(scenario) -> bool:
    return scenario.system == "gyrostat_pair" and scenario.stages["estimator"][0] == "invariant_manifold"


def _w3_error(run) -> np.ndarray:
    return run.recorder["estimator/omega"][:, 2] - run.recorder["truth/omega"][:, 2]


def _valid(run):
    """Samples where the estimator ran (the final row holds the truth only)."""
    return np.isfinite(run.recorder["estimator/omega"][:, 0])


@metric("observer_decay_rate_1_s", applies=_observer)
def observer_decay_rate_1_s(run) -> float:
    """Decay rate fitted to |w3_estimate - w3| (eq. 14: eta' = -gamma eta) [1/s]."""
    ok = _valid(run)
    return fitted_decay_rate(run.recorder.time[ok], _w3_error(run)[ok])


@metric("observer_decay_rate_error_rel", applies=_observer)
def observer_decay_rate_error_rel(run) -> float:
    """|fitted decay rate - gamma| / gamma."""
    gamma = run.scenario.stages["estimator"][1].gamma_1_s
    return abs(observer_decay_rate_1_s(run) - gamma) / gamma


@metric("observer_final_error_rad_s", applies=_observer)
def observer_final_error_rad_s(run) -> float:
    """|w_estimate - w| (all three components) at the last estimate [rad/s]."""
    ok = _valid(run)
    error = run.recorder["estimator/omega"][ok] - run.recorder["truth/omega"][ok]
    return float(np.linalg.norm(error[-1]))


# --- seed 003: synchronisation ---------------------------------------------------------------

def _sync(scenario) -> bool:
    return scenario.system == "gyrostat_pair" and scenario.stages["law"][0] == "synchronisation"


@metric("sync_final_error_rad_s", applies=_sync)
def sync_final_error_rad_s(run) -> float:
    """|p - w|, follower minus leader angular velocity, at the end [rad/s]."""
    return float(_norms(run, "truth/sync_error")[-1])


@metric("sync_decay_rate_1_s", applies=_sync)
def sync_decay_rate_1_s(run) -> float:
    """Decay rate fitted to |p - w| from its peak down to 1e-4 of it [1/s]."""
    return fitted_decay_rate(run.recorder.time, _norms(run, "truth/sync_error"))
