"""Per-call time of each steering law on random rhombus-cluster cases; exact vs LP speed-up.

Run: .venv/bin/python bench/bench_minimax.py [n_cases]
Prints microseconds per call for every law in STEERING_LAWS and `exact_over_lp`, the LP
min-max time divided by the closed-form min-max time (the goal is >= 100).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout, uninstalled
from testbed.steering import STEERING_LAWS  # noqa: E402
from testbed.systems.cmg_cluster.cluster import ClusterGeometry  # noqa: E402
from testbed.systems.cmg_rhombus import CmgRhombusParams, build  # noqa: E402


def random_cases(n: int, seed: int = 0):
    """n (J, Hdot) pairs: random gimbal angles (alpha = 50 deg) and demands of 0.1-10 N m."""
    rng = np.random.default_rng(seed)
    geometry = ClusterGeometry.from_model(build(CmgRhombusParams(alpha_deg=50.0), dt=1e-3))
    cases = []
    for _ in range(n):
        J = geometry.unit_jacobian(rng.uniform(-np.pi, np.pi, 4))
        cases.append((J, rng.normal(size=3) * 10.0 ** rng.uniform(-1, 1)))
    return cases


def us_per_call(law, cases, h: float, beta_rate_max: float, repeats: int) -> float:
    """Best-of-`repeats` mean CPU time of law over all cases, in microseconds per call."""
    best = np.inf
    for _ in range(repeats):
        start = time.process_time()  # CPU time: steadier than wall time on shared cores
        for J, hdot in cases:
            law(J, h, hdot, beta_rate_max)
        best = min(best, (time.process_time() - start) / len(cases))
    return best * 1e6


def main(n_cases: int = 2000) -> dict[str, float]:
    cases = random_cases(n_cases)
    h, beta_rate_max = 20.0, 1.0  # N m s, rad/s: some cases saturate, most do not
    times = {}
    for name, law in STEERING_LAWS.items():
        lp = name == "minimax_lp"  # ~1 ms a call: fewer cases, one pass
        times[name] = us_per_call(law, cases[: n_cases // 10] if lp else cases, h,
                                  beta_rate_max, 1 if lp else 3)
        print(f"{name:>11s}: {times[name]:9.2f} us/call")
    ratio = times["minimax_lp"] / times["minimax"]
    print(f"exact_over_lp: {ratio:.0f}x faster")
    return times


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 2000)
