"""Metrics of the CMG spacecraft's actuators: servo tracking, the rotor speeds of variable-speed rotors
(the steering metrics live with the steering stages)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from testbed.metrics import metric
from testbed.pipeline import output_of
from testbed.systems.cmg_cluster.cluster import CLUSTER_SYSTEMS


def _servo_commanded(scenario) -> bool:
    """The allocator commands gimbal rates (not only ideal torques, not nothing)."""
    return scenario.system in CLUSTER_SYSTEMS and output_of("allocator", scenario.stages["allocator"][0]) == "gimbal_rates"


@dataclass(frozen=True)
class _TrackingPeaks:
    """Per gimbal, as the run goes: max_t |cmd_i| and max_{t > 0.1 s} |b'_i - cmd_i| (NaN rows skipped)."""

    def start(self):
        return None, None

    def update(self, state, chunk):
        if "truth/gimbal_rate" not in chunk or len(chunk.time) == 0:
            return state
        command, error_peak = chunk["truth/gimbal_rate_command"], state[1]
        keep = chunk.time > 0.1
        command_peak = _nanmax(state[0], np.abs(command))
        if keep.any():
            error_peak = _nanmax(error_peak, np.abs(chunk["truth/gimbal_rate"][keep] - command[keep]))
        return command_peak, error_peak

    def result(self, state):
        return state


def _nanmax(peak, values):
    """np.nanmax over rows, kept across chunks (NaN only where every row so far was NaN)."""
    chunk_peak = np.nanmax(values, axis=0)
    return chunk_peak if peak is None else np.fmax(peak, chunk_peak)


TRACKING_PEAKS = _TrackingPeaks()


@metric("gimbal_rate_error_rel", applies=_servo_commanded, uses=(TRACKING_PEAKS,))
def gimbal_rate_error_rel(run) -> float:
    """max_i max_t |b'_i(t_k+1) - cmd_i(t_k)| / max_t |cmd_i|: servo tracking of the held command, after 0.1 s."""
    # each trace sample holds the rate b'(t_k+1) and the command held over (t_k, t_k+1]
    # (truth/gimbal_rate_command), so any trace period measures the end of a hold;
    # max_t (|e_i| / s_i) = (max_t |e_i|) / s_i exactly: division by s_i > 0 keeps the order
    command_peak, error_peak = run.reduced(TRACKING_PEAKS)
    if error_peak is None:
        raise ValueError("no gimbal rates recorded after 0.1 s")
    scale = np.maximum(command_peak, 1e-12)
    return float(np.nanmax(error_peak / scale))


def _variable_speed(scenario) -> bool:
    """The rotors may change speed (model.rotor_speed_range_rpm given)."""
    return scenario.system in CLUSTER_SYSTEMS and scenario.model.rotor_speed_range_rpm is not None


@dataclass(frozen=True)
class _SpeedExtremes:
    """(min, max) over samples and rotors of truth/rotor_rate, as the run goes."""

    def start(self):
        return np.inf, -np.inf

    def update(self, state, chunk):
        if "truth/rotor_rate" not in chunk or len(chunk.time) == 0:
            return state
        speeds = chunk["truth/rotor_rate"]
        return min(state[0], float(np.min(speeds))), max(state[1], float(np.max(speeds)))

    def result(self, state):
        return state


def _in_orbit(scenario) -> bool:
    return scenario.system in CLUSTER_SYSTEMS and scenario.orbit is not None


@dataclass(frozen=True)
class _EnvelopeShare:
    """As the run goes: the peak of truth/envelope_share and the first time it reaches 0.9."""

    def start(self):
        return None, float("nan")

    def update(self, state, chunk):
        if "truth/envelope_share" not in chunk or len(chunk.time) == 0:
            return state
        share = chunk["truth/envelope_share"][:, 0]
        peak, reached = state
        peak = _nanmax(peak, share[:, None])
        full = np.nonzero(share >= 0.9)[0]
        if full.size and np.isnan(reached):
            reached = float(chunk.time[full[0]])
        return peak, reached

    def result(self, state):
        return state


SPEED_EXTREMES = _SpeedExtremes()


@metric("min_rotor_speed_rpm", applies=_variable_speed, uses=(SPEED_EXTREMES,))
def min_rotor_speed_rpm(run) -> float:
    """min over trace samples and rotors of the true rotor speed relative to its gimbal [rpm]."""
    return float(run.reduced(SPEED_EXTREMES)[0] * 30.0 / np.pi)


@metric("max_rotor_speed_rpm", applies=_variable_speed, uses=(SPEED_EXTREMES,))
def max_rotor_speed_rpm(run) -> float:
    """max over trace samples and rotors of the true rotor speed relative to its gimbal [rpm]."""
    return float(run.reduced(SPEED_EXTREMES)[1] * 30.0 / np.pi)


def _faulted_and_watched(scenario) -> bool:
    """A fault is injected (model.faults) and the allocator looks for it (fault_detection)."""
    return (scenario.system in CLUSTER_SYSTEMS and bool(scenario.model.faults)
            and bool(getattr(scenario.stages["allocator"][1], "fault_detection", False)))


@metric("fault_isolated_correctly", applies=_faulted_and_watched, uses=())
def fault_isolated_correctly(run) -> float:
    """1 when the unit the detection declared failed first is the first unit model.faults breaks, else 0."""
    first = min(run.scenario.model.faults, key=lambda f: f.at_s)
    return float(run.statistics["allocator"]["isolated_unit"] == first.unit)


@metric("fault_isolation_delay_s", applies=_faulted_and_watched, uses=())
def fault_isolation_delay_s(run) -> float:
    """Time from the first fault's at_s to the first isolation [s] (NaN: none; < 0: a false alarm before it)."""
    first = min(run.scenario.model.faults, key=lambda f: f.at_s)
    return float(run.statistics["allocator"]["isolation_time"] - first.at_s)


ENVELOPE_SHARE = _EnvelopeShare()


@metric("peak_envelope_share", applies=_in_orbit, uses=(ENVELOPE_SHARE,))
def peak_envelope_share(run) -> float:
    """max_t of the cluster momentum's share of its envelope (the gauge; 1 on the envelope)."""
    peak = run.reduced(ENVELOPE_SHARE)[0]
    return float("nan") if peak is None else float(peak[0])


@metric("envelope_90_time_s", applies=_in_orbit, uses=(ENVELOPE_SHARE,))
def envelope_90_time_s(run) -> float:
    """first time the cluster momentum reaches 90 % of its envelope [s] (NaN: not within the run)."""
    return run.reduced(ENVELOPE_SHARE)[1]
