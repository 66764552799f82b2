"""The steering allocators' batched form alone: cost per world-tick against the single stage's tick.

    python bench/bench_batch_steering.py [--ticks T] [N ...]

For each law with a form on rows (testbed.steering.batched_stage.ROW_LAWS), N worlds of the
reorient_minimax cluster at scattered gimbal angles and demands; T ticks of `allocate` through the
batched form, against the same ticks through each world's own stage one by one. Prints microseconds
per world-tick (the least CPU time of REPEATS) and the ratio. The stage alone: no physics, no other slots.
"""

from __future__ import annotations

import argparse
import copy
import time

import numpy as np

import testbed
from testbed.run_core.plan import prepare
from testbed.steering.batched_stage import ROW_LAWS, BatchedSteering

REPEATS = 3
SIZES = (1, 16, 64, 256)


def worlds(law: str, count: int):
    """`count` copies of the reorient_minimax allocator under `law` (one compiled model, stages copied)."""
    stage = prepare(testbed.load("reorient_minimax", ["sim.duration_s=1", f"pipeline.allocator.type={law}"])
                    ).pipeline.stages()["allocator"]
    return [copy.deepcopy(stage) for _ in range(count)]


def inputs(count: int, ticks: int, seed: int = 5):
    """Per tick: gimbal angles [rad] spread over the sphere of sets, wanted torques [N m] and rates [rad/s]."""
    rng = np.random.default_rng(seed)
    beta = rng.uniform(-np.pi, np.pi, (ticks, count, 4))
    torque = rng.normal(0.0, 3.0, (ticks, count, 3))
    omega = rng.normal(0.0, 0.01, (ticks, count, 3))
    rotor = np.full((count, 4), 628.3185307179587)
    return [({"torque": torque[k]}, {"omega": omega[k]},
             {"gimbal_angle": beta[k], "rotor_rate": rotor, "gimbal_rate": np.zeros((count, 4))})
            for k in range(ticks)]


def best(call) -> float:
    """The least CPU seconds of REPEATS calls (CPU, not wall: the machine may be shared)."""
    times = []
    for _ in range(REPEATS):
        start = time.process_time()
        call()
        times.append(time.process_time() - start)
    return min(times)


def measure(law: str, count: int, ticks: int) -> tuple[float, float]:
    """(batched, single) microseconds per world-tick."""
    given = inputs(count, ticks)
    form = BatchedSteering(worlds(law, count), ROW_LAWS[law])
    singles = worlds(law, count)
    rows = [[({"torque": d["torque"][i]}, {"omega": e["omega"][i]}, {key: v[i] for key, v in a.items()})
             for i in range(count)] for d, e, a in given]

    def batched():
        for k, (demand, estimate, actuators) in enumerate(given):
            form.allocate(0.05 * k, demand, estimate, actuators)

    def single():
        for k, tick in enumerate(rows):
            for stage, (demand, estimate, actuators) in zip(singles, tick):
                stage.allocate(0.05 * k, demand, estimate, actuators)

    with np.errstate(over="raise", invalid="raise", divide="raise"):  # as a run steps them
        return 1e6 * best(batched) / (count * ticks), 1e6 * best(single) / (count * ticks)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ticks", type=int, default=200)
    parser.add_argument("sizes", type=int, nargs="*", default=list(SIZES))
    args = parser.parse_args()
    print(f"{'law':8s} {'N':>5s} {'batched us':>11s} {'single us':>10s} {'ratio':>7s}  (per world-tick)")
    for law in ROW_LAWS:
        for count in args.sizes:
            ticks = max(4, args.ticks * 16 // max(count, 16))
            batched, single = measure(law, count, ticks)
            print(f"{law:8s} {count:5d} {batched:11.2f} {single:10.2f} {batched / single:7.3f}", flush=True)


if __name__ == "__main__":
    main()
