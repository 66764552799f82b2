"""One side of bench/bench_speed_regression.py: runs the scenarios it is given, in this
process, with whatever `testbed` is first on the path (the parent points PYTHONPATH at the
baseline's tree or at the current one), and prints one JSON line: the `testbed` package it ran
and, per scenario, its wall and CPU seconds and its simulated seconds. Imports and the
scenario's loading are outside the timed span: the figure is the run's own.

Only the public API (`testbed.load`, `testbed.run` with `keep_trace`) is used, so any tree that
has them runs it; an older one fails with its error named.

    python bench/speed_probe.py '{"cmg_open_loop": ["sim.duration_s=120", "reference=", "checks={}"]}'
"""

import json
import sys
import time

import testbed


def main() -> None:
    cases = json.loads(sys.argv[1])
    runs = {}
    for name, overrides in cases.items():
        scenario = testbed.load(name, overrides)
        wall0, cpu0 = time.perf_counter(), time.process_time()
        result = testbed.run(scenario, None, keep_trace=False)
        runs[name] = {"wall_s": time.perf_counter() - wall0, "cpu_s": time.process_time() - cpu0,
                      "sim_s": result.sim_s, "status": result.status, "error": result.error}
    print(json.dumps({"testbed": testbed.__file__, "runs": runs}))


if __name__ == "__main__":
    main()
