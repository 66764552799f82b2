"""What the flagship's sensor, estimator and law cost a world-tick on a batch's (N, ...) arrays.

    .venv/bin/python bench/bench_batch_lebedev_forms.py [N ...]     (default 1 16 64 256)

N worlds of lebedev_spinup_cmg (noisy gyro, each its own seed, the bus at rest at the wanted
spin so the estimates stay at the operating point) run `rate_gyro`, `lebedev` and `lebedev`
alone, no physics, for the start-up phase (eq. 3.1, t < 150 s) and the closed loop (eq. 4.6 and
the validity test): their batched forms (testbed.batch.stage_forms) against each world's own
stages one by one. Printed: microseconds a world-tick each way and their ratio. A world-tick of
the flagship's physics alone is about 74 us.
"""

from __future__ import annotations

import sys
import time

import numpy as np

import testbed
from testbed.batch.stage_forms import forms_of
from testbed.run_core.plan import prepare


def _plans(n: int) -> list:
    return [prepare(testbed.load("lebedev_spinup_cmg", [
        "sim.duration_s=1", "model.cancel_initial_momentum=true", f"initial.omega_deg_s=[0, 0, {1 + 1e-4 * i}]",
        "pipeline.sensor.noise_sigma_rad_s=1e-6", f"pipeline.sensor.seed={i}"])) for i in range(n)]


def cost(n: int, ticks: int, t0: float) -> tuple[float, float]:
    """(batched, per world) [us a world-tick] over `ticks` control periods from t0 [s]."""
    plans = _plans(n)
    pipelines, plants = [plan.pipeline for plan in plans], [plan.plant for plan in plans]
    forms = forms_of(pipelines)
    sensor, estimator, law = forms["sensor"], forms["estimator"], forms["law"]
    key = pipelines[0].estimator.torque_key
    with np.errstate(over="raise", invalid="raise", divide="raise"):
        command = {key: np.zeros((n, 3))}
        start = time.perf_counter()
        for k in range(ticks):
            t = t0 + 0.05 * k
            law.torque(t, estimator.estimate(t, sensor.measure(t, plants), command))
        batched = time.perf_counter() - start
        own = [(p.pipeline.sensor, p.pipeline.estimator, p.pipeline.law) for p in _plans(n)]
        command = {key: np.zeros(3)}
        start = time.perf_counter()
        for k in range(ticks):
            t = t0 + 0.05 * k
            for (gyro, observer, control), plant in zip(own, plants):
                control.torque(t, observer.estimate(t, gyro.measure(t, plant), command))
        alone = time.perf_counter() - start
    return batched / (ticks * n) * 1e6, alone / (ticks * n) * 1e6


def main(counts: list[int]) -> None:
    for n in counts:
        for phase, t0 in (("start-up", 0.0), ("closed", 150.0)):
            batched, alone = cost(n, max(100, 2000 // n), t0)
            print(f"N = {n:4d} {phase:8s}: batched {batched:7.2f} us a world-tick, each world alone "
                  f"{alone:6.2f} us ({alone / batched:5.1f}x)")


if __name__ == "__main__":
    main([int(arg) for arg in sys.argv[1:]] or [1, 16, 64, 256])
