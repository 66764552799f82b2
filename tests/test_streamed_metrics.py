"""Metrics from the streamed trace equal the whole-history numpy expressions, on every shipped
scenario (issue 15: "computed without the whole history in memory ... equal to 1e-12").

Streamed: the run as `testbed run` makes it (only the signals the metrics declare are kept),
in chunks of CHUNK so that every window and phase boundary falls inside some chunk. Whole
history: the same scenario with keep_data=True, each running reduction replaced by the numpy
expression its docstring gives, evaluated over the whole recorded history at once
(`whole_history_value`), a second method that shares no code with testbed.recording.reductions (a
system's own reduction, the CMG servo tracking peaks, is fed the whole history as one chunk).
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
import pytest

import testbed.run_core.in_progress
from testbed import metrics
from testbed.recording import reductions
from testbed.recording.recorder import Chunk, Recorder
from testbed.runner import run_scenario
from testbed.scenario.loading import load_scenario
from testbed.scenario.shipped_files import SCENARIO_DIR

CHUNK = 61  # samples a chunk: prime, so chunk edges fall everywhere
RTOL = 1e-12
# Shorter runs where the shipped one is long; the Lebedev estimator's start-up phase shortened
# with them, so that every phase (start-up, closing, the tails) is in the run.
SHORT = {
    "agile_slew_flexible": ["sim.duration_s=50"],           # past the slew's end: the settling window
    "agile_slew_flexible_campaign": ["sim.duration_s=50"],
    "agile_slew_flexible_shaped": ["sim.duration_s=50"],
    "akor_sweep": ["sim.duration_s=70"],
    "cmg_open_loop": ["sim.duration_s=20"],
    "gyrostat_free": ["sim.duration_s=60"],
    "gyrostat_program": ["sim.duration_s=20"],
    "lebedev_detumble_ideal": ["sim.duration_s=400", "pipeline.estimator.startup_s=100"],
    "lebedev_gyro_bias": ["sim.duration_s=200"],  # the shipped 150 s start-up: shorter, the observer diverges
    "lebedev_gyro_noise": ["sim.duration_s=200"],  # the shipped 150 s start-up: shorter, the observer diverges
    "lebedev_spinup_campaign": ["sim.duration_s=60", "pipeline.estimator.startup_s=20"],
    "lebedev_spinup_cmg": ["sim.duration_s=60", "pipeline.estimator.startup_s=20"],
    "lebedev_spinup_cmg_momentum": ["sim.duration_s=60", "pipeline.estimator.startup_s=20"],
    "lebedev_spinup_ideal": ["sim.duration_s=200"],  # the shipped 150 s start-up: shorter, the observer diverges
    "reorient_campaign": ["sim.duration_s=20"],
    "reorient_gimbal_limits": ["sim.duration_s=20"],
    "reorient_minimax": ["sim.duration_s=20"],
    "reorient_minimax_avoid": ["sim.duration_s=20"],
    "reorient_near_singular": ["sim.duration_s=20"],
    "reorient_near_singular_avoid": ["sim.duration_s=20"],
    "reorient_near_singular_vscmg": ["sim.duration_s=20"],
    "reorient_gimbal_stuck": ["sim.duration_s=25"],      # past the fault at 20 s
    "reorient_fault_campaign": ["sim.duration_s=25"],
    "reorient_fault_free_campaign": ["sim.duration_s=20"],
    "rotor_imbalance_jitter": ["sim.duration_s=0.5"],
    "orbit_momentum_buildup": ["sim.duration_s=300"],        # past the pointing metric's 60 s settling
    "orbit_momentum_management": ["sim.duration_s=300"],
    "orbit_momentum_campaign": ["sim.duration_s=300"],
    "reorient_pinv": ["sim.duration_s=20"],
    "torque_free_skylab": ["sim.duration_s=100"],
    "torque_free_tumble": ["sim.duration_s=200"],
}


def scenario_names() -> list[str]:
    return sorted(p.stem for p in SCENARIO_DIR.glob("*.yaml"))


def _tail(t: np.ndarray, fraction: float) -> np.ndarray:
    return t >= t[-1] - fraction * (t[-1] - t[0])


def _envelope_ratio(t, norms, window) -> float:
    index = np.floor((t - t[0]) / window + 1e-9).astype(int)
    peaks = np.array([np.max(norms[index == k]) for k in range(index.max() + 1) if np.any(index == k)])
    return float(np.max(peaks[1:] / peaks[:-1])) if len(peaks) >= 2 else float("nan")


OF_SIGNAL = {reductions.MaxNorm: lambda v: float(np.max(np.linalg.norm(v, axis=1))),
             reductions.MaxAbs: lambda v: float(np.max(np.abs(v))),
             reductions.MaxDistanceFromFirst: lambda v: float(np.max(np.linalg.norm(v - v[0], axis=1))),
             reductions.First: lambda v: v[0],
             reductions.Last: lambda v: v[-1],
             reductions.NanMax: lambda v: float(np.nanmax(v))}


def whole_history_value(reduction, history: Chunk):
    """The numpy expression a reduction stands for, over the whole history (one row a sample)."""
    t = history.time
    if isinstance(reduction, reductions.WindowPeakRatio):
        return _envelope_ratio(t, np.linalg.norm(history[reduction.key], axis=1), reduction.window)
    if hasattr(reduction, "key") and type(reduction) in OF_SIGNAL:
        return OF_SIGNAL[type(reduction)](history[reduction.key])
    if not hasattr(reduction, "rows"):  # a method's or system's own reduction: the whole history as one chunk
        return reduction.result(reduction.update(reduction.start(), history))
    rows = reduction.rows(history)
    if isinstance(reduction, reductions.Mean):
        return np.mean(rows, axis=0)
    if isinstance(reduction, reductions.NanMaxBefore):
        early = t < reduction.until
        return np.nanmax(rows[early], axis=0) if early.any() else np.nan
    if isinstance(reduction, reductions.FirstFrom):
        after = np.flatnonzero(t >= reduction.at)
        return rows[after[0]] if after.size else np.nan
    tail = _tail(t, reduction.fraction)
    return {reductions.TailMean: np.mean, reductions.TailNanMax: np.nanmax}[type(reduction)](rows[tail], axis=0)


@dataclasses.dataclass
class _WholeHistory:
    """Stands in for a run's Reductions: each value from the whole history at once."""

    history: Chunk

    def value(self, reduction):
        return whole_history_value(reduction, self.history)


def whole_history_metrics(name: str) -> dict[str, float]:
    result = run_scenario(load_scenario(name, SHORT.get(name, [])), None, keep_data=True)
    assert result.status == "ok", result.error
    recorder = result.data.recorder
    history = Chunk(0, recorder.time, {key: recorder[key] for key in recorder.keys() if key in recorder})
    values, _ = metrics.compute_all(dataclasses.replace(result.data, reductions=_WholeHistory(history), _shared={}))
    return values


def streamed_metrics(name: str, monkeypatch) -> dict[str, float]:
    monkeypatch.setattr(testbed.run_core.in_progress, "Recorder", functools.partial(Recorder, chunk_rows=CHUNK))
    result = run_scenario(load_scenario(name, SHORT.get(name, [])), None)
    assert result.status == "ok", result.error
    return result.metrics


@pytest.mark.parametrize("name", scenario_names())
def test_streamed_metrics_equal_the_whole_history_ones(name, monkeypatch):
    whole, streamed = whole_history_metrics(name), streamed_metrics(name, monkeypatch)
    assert sorted(streamed) == sorted(whole)
    for key, value in whole.items():
        if math.isnan(value):
            assert math.isnan(streamed[key]), key
        else:
            assert streamed[key] == pytest.approx(value, rel=RTOL, abs=0.0), key


@pytest.mark.parametrize("name", ["lebedev_spinup_cmg", "reorient_pinv"])
def test_the_flagship_and_a_slew_keep_no_signal_history(name):
    """Every metric of the flagship and of a slew is a running reduction: the run keeps no signal."""
    assert metrics.kept_signals(load_scenario(name)) == set()


FAILS_AT_S = 177.3
FAILING_GYRO = f'''\
from testbed.pipeline import stage
from testbed.stages.rate_gyro import RateGyro, RateGyroParams


@stage("sensor", "test.failing_gyro", RateGyroParams)
class FailingGyro(RateGyro):
    """The rate gyro, until it fails at t = {FAILS_AT_S} s (the run ends there, status "error")."""

    def measure(self, t, plant):
        if t >= {FAILS_AT_S}:
            raise RuntimeError("the gyro failed")
        return super().measure(t, plant)
'''


def test_a_run_cut_short_gives_the_whole_history_metrics(tmp_path, monkeypatch):
    """A Lebedev run planned for 250 s whose gyro fails at 177.3 s: its last 20 % and 10 % are
    windows over the run it had, not the planned one, and streamed they are the same numbers."""
    import yaml

    (tmp_path / "failing_gyro.py").write_text(FAILING_GYRO)
    data = yaml.safe_load((SCENARIO_DIR / "lebedev_spinup_ideal.yaml").read_text())
    data["plugins"] = ["failing_gyro.py"]
    data["pipeline"]["sensor"]["type"] = "test.failing_gyro"
    data["sim"]["duration_s"] = 250  # the shipped 150 s start-up: shorter, the observer diverges
    data.pop("reference")  # it needs the shipped gyro
    data["checks"] = {}
    (tmp_path / "cut.yaml").write_text(yaml.safe_dump(data))
    scenario = load_scenario(str(tmp_path / "cut.yaml"))
    whole = run_scenario(scenario, None, keep_data=True)
    assert whole.status == "error" and whole.sim_s < FAILS_AT_S
    recorder = whole.data.recorder
    history = Chunk(0, recorder.time, {key: recorder[key] for key in recorder.keys() if key in recorder})
    expected, _ = metrics.compute_all(dataclasses.replace(whole.data, reductions=_WholeHistory(history), _shared={}))
    monkeypatch.setattr(testbed.run_core.in_progress, "Recorder", functools.partial(Recorder, chunk_rows=CHUNK))
    streamed = run_scenario(scenario, None).metrics
    for key in ("spin_error_steady_deg_s", "spin_rate_offset_deg_s", "transverse_rate_steady_deg_s",
                "estimation_error_final_deg_s", "estimation_error_at_closing_deg_s"):
        assert np.isfinite(expected[key])
        assert streamed[key] == pytest.approx(expected[key], rel=RTOL, abs=0.0), key
