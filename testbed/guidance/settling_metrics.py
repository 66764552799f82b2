"""Slew-and-settle metrics of the `slew` law, from the truth after the program comes to rest
(its `slew_end_s`): settling times to the scenario's pointing and rate-jitter bounds, and the
bus-rate spectrum over that window (written into the trace, its peak a metric)."""

from __future__ import annotations

import numpy as np

from testbed.guidance.settling import rate_spectrum, settling_time, spectral_peak
from testbed.math.quaternion import quat_angle, quat_conj, quat_mul
from testbed.metrics import metric
from testbed.recording.spectra import spectrum


def _slew_params(scenario):
    name, params = scenario.stages["law"]
    return params if name == "slew" else None


def _pointing_bound(scenario) -> bool:
    params = _slew_params(scenario)
    return params is not None and params.settle_pointing_deg is not None


def _rate_bound(scenario) -> bool:
    params = _slew_params(scenario)
    return params is not None and params.settle_rate_deg_s is not None


@metric("settling_time_pointing_s", applies=_pointing_bound, uses=("truth/quat",))
def settling_time_pointing_s(run) -> float:
    """Time after the slew's end until the pointing error stays within settle_pointing_deg [s]."""
    law = run.statistics["law"]
    error = quat_angle(quat_mul(quat_conj(law["target_quat"]), run.recorder["truth/quat"]))
    bound = np.radians(_slew_params(run.scenario).settle_pointing_deg)
    return settling_time(run.recorder.time, error, bound, law["slew_end_s"])


@metric("settling_time_rate_s", applies=_rate_bound, uses=("truth/omega",))
def settling_time_rate_s(run) -> float:
    """Time after the slew's end until the bus rate |w| stays within settle_rate_deg_s [s]."""
    bound = np.radians(_slew_params(run.scenario).settle_rate_deg_s)
    return settling_time(run.recorder.time, np.linalg.norm(run.recorder["truth/omega"], axis=1), bound,
                         run.statistics["law"]["slew_end_s"])


def _spectrum(run):
    return run.shared("bus_rate_psd", lambda: rate_spectrum(run.recorder.time, run.recorder["truth/omega"],
                                                            run.statistics["law"]["slew_end_s"]))


@spectrum("bus_rate_psd", applies=_rate_bound, uses=("truth/omega",), unit="(rad/s)^2/Hz")
def bus_rate_psd(run):
    """Bus-rate PSD after the slew (Welch)"""
    return _spectrum(run)


@metric("jitter_peak_hz", applies=_rate_bound, uses=("truth/omega",))
def jitter_peak_hz(run) -> float:
    """Frequency of the bus-rate PSD's peak after the slew's end (Welch, the peak's bin refined by a Gaussian) [Hz]."""
    return spectral_peak(*_spectrum(run))
