"""Speed regression guard: fails (exit 1) when a shipped scenario's wall time per simulated
second has grown by more than `max_growth` (15 %) against a committed baseline.

The baseline is a commit (`ref` in bench/speed_baseline.json), not a stored time: the script
exports that commit's tree to a temporary directory and runs it and the current tree on this
machine, in this call, alternately (baseline, current, baseline, current, ...; `--rounds`
pairs, after one round of each that is not counted: it compiles the exported tree's
bytecode), each round in a fresh process (bench/speed_probe.py, with PYTHONPATH pointing at the
tree it measures; both use this venv's libraries). Per scenario the verdict is the ratio of the
current tree's fastest run to the baseline's fastest, in wall seconds per simulated second:
other load on the machine only ever adds time, so each side's fastest run is the nearest to
its own cost, and comparing the two sides of one call cancels the machine's speed. The median
of the round-by-round ratios and the CPU-time ratio are printed beside it. When a side's fastest
run still spent more than LOADED_WALL_OVER_CPU times its CPU time in wall time, the machine was
busy and its wall figures say more about the load than about the code: that scenario is then
judged on the ratio of CPU time per simulated second (what its wall time would be on an idle
core: the runs are single-threaded), and the script says so.

Runs use the scenarios' own settings but for the overrides listed in the baseline file (a
shorter duration where the full run is long), with the analytic reference and the checks off:
the figure is the run's own per-tick path (stages, servo, physics, trace samples, metrics).
Accept a slowdown, or a speed-up, by moving `ref` to the commit that makes it, with the
figures this script prints in the commit message.

    .venv/bin/python bench/bench_speed_regression.py [--rounds N] [--baseline REF] [--scenario NAME ...]

Exit status: 0 no scenario over the limit, 1 a regression (named on stderr), 2 the
benchmark could not run (a bad ref, a run that failed or timed out).
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import statistics
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
BASELINE_FILE = Path(__file__).with_name("speed_baseline.json")
PROBE = Path(__file__).with_name("speed_probe.py")
# What every run is given besides the file's overrides: no analytic reference (an oracle, not
# a user's run), and so no checks (several read the reference's error).
RUN_OVERRIDES = ["reference=", "checks={}"]
# Wall over CPU time of a quiet single-threaded run is about 1.05 (.rrd-less, no BLAS threads)
LOADED_WALL_OVER_CPU = 1.3
PROBE_TIMEOUT_S = 900.0  # one side's round of every scenario; a hang ends the benchmark


class BenchError(Exception):
    """The benchmark cannot give a verdict (exit 2)."""


def _ended_by_signal(signum, _frame):
    raise SystemExit(128 + signum)  # unwinds: the probe is killed and the exported tree removed


def export_tree(ref: str, into: Path) -> str:
    """The tree of commit `ref` written under `into` (git archive: nothing is registered in the
    repository, so an interrupted run leaves no worktree behind); returns the full hash."""
    found = subprocess.run(["git", "-C", str(REPO), "rev-parse", "--verify", "--quiet", f"{ref}^{{commit}}"],
                           capture_output=True, text=True)
    if found.returncode != 0:
        raise BenchError(f"{BASELINE_FILE.name}: ref: {ref!r} is not a commit of this repository")
    commit = found.stdout.strip()
    archive = subprocess.Popen(["git", "-C", str(REPO), "archive", "--format=tar", commit], stdout=subprocess.PIPE)
    try:
        with tarfile.open(fileobj=archive.stdout, mode="r|") as tar:
            tar.extractall(into, filter="data")
    finally:
        archive.stdout.close()
        if archive.wait() != 0:
            raise BenchError(f"git archive {commit} failed (exit {archive.returncode})")
    return commit


def probe(tree: Path, cases: dict[str, list[str]], side: str) -> dict:
    """One round of every case on `tree`, in a fresh process: {name: {wall_s, cpu_s, sim_s, ...}}."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    process = subprocess.Popen([sys.executable, str(PROBE), json.dumps(cases)], cwd=tempfile.gettempdir(),
                               env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        out, err = process.communicate(timeout=PROBE_TIMEOUT_S)
    except subprocess.TimeoutExpired:
        raise BenchError(f"the {side} tree's runs took more than {PROBE_TIMEOUT_S:g} s") from None
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    if process.returncode != 0:
        last = (err.strip().splitlines() or ["no output"])[-1]
        raise BenchError(f"the {side} tree's runs failed (exit {process.returncode}): {last}")
    try:
        report = json.loads(out.strip().splitlines()[-1])
    except (ValueError, IndexError):
        raise BenchError(f"the {side} tree's runs printed no result") from None
    ran = Path(report["testbed"]).resolve().parent.parent
    if ran != tree.resolve():  # an installed testbed shadowing the tree would compare a tree with itself
        raise BenchError(f"the {side} runs imported testbed from {ran}, not from {tree}")
    for name, run in report["runs"].items():
        if run["status"] != "ok":
            raise BenchError(f"{name} on the {side} tree ended {run['status']}: {run['error']}")
    return report["runs"]


def read_baseline() -> dict:
    """bench/speed_baseline.json, checked: ref (a git ref), max_growth (> 0), rounds (>= 1),
    scenarios (name -> list of override strings)."""
    try:
        config = json.loads(BASELINE_FILE.read_text())
    except (OSError, ValueError) as exc:
        raise BenchError(f"{BASELINE_FILE.name}: cannot be read as JSON ({exc})") from None
    checks = {"ref": lambda v: isinstance(v, str) and v.strip() != "",
              "max_growth": lambda v: isinstance(v, (int, float)) and not isinstance(v, bool) and v > 0,
              "rounds": lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= 1,
              "scenarios": lambda v: isinstance(v, dict) and v and all(
                  isinstance(o, list) and all(isinstance(x, str) for x in o) for o in v.values())}
    reasons = {"ref": "must be a git ref (a commit hash or name)", "max_growth": "must be a number > 0",
               "rounds": "must be an integer >= 1",
               "scenarios": "must map scenario names to lists of key.path=value overrides"}
    for key, ok in checks.items():
        if key not in config or not ok(config[key]):
            raise BenchError(f"{BASELINE_FILE.name}: {key}: {reasons[key]}")
    return config


def per_sim_second(runs: list[dict], key: str) -> list[float]:
    return [run[key] / run["sim_s"] for run in runs]


def busy_machine(runs: list[dict]) -> bool:
    """Whether even the fastest of these runs waited for the processor (wall over CPU time)."""
    fastest = min(runs, key=lambda run: run["wall_s"])
    return fastest["wall_s"] > LOADED_WALL_OVER_CPU * fastest["cpu_s"]


def main() -> int:
    signal.signal(signal.SIGTERM, _ended_by_signal)
    signal.signal(signal.SIGHUP, _ended_by_signal)
    config = read_baseline()
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=config["rounds"],
                        help="alternating baseline/current pairs (default %(default)s)")
    parser.add_argument("--baseline", default=config["ref"], help="the commit to compare with (default: the file's)")
    parser.add_argument("--scenario", action="append", choices=sorted(config["scenarios"]),
                        help="only this scenario (repeatable; default: every one in the file)")
    args = parser.parse_args()
    if args.rounds < 1:
        parser.error("--rounds: must be at least 1")
    limit = float(config["max_growth"])
    names = args.scenario or list(config["scenarios"])
    cases = {name: list(config["scenarios"][name]) + RUN_OVERRIDES for name in names}
    with tempfile.TemporaryDirectory(prefix="speed-baseline-") as tmp:
        commit = export_tree(args.baseline, Path(tmp))
        print(f"baseline {args.baseline} ({commit[:12]}) against the current tree {REPO}; "
              f"{args.rounds} alternating rounds; limit +{limit:.0%} wall time per simulated second", flush=True)
        rounds = {"baseline": [], "current": []}
        probe(Path(tmp), cases, "baseline")  # the warm-up round of each side, not counted
        probe(REPO, cases, "current")
        for k in range(args.rounds):
            rounds["baseline"].append(probe(Path(tmp), cases, "baseline"))
            rounds["current"].append(probe(REPO, cases, "current"))
            print(f"  round {k + 1} of {args.rounds} done", flush=True)
    width = max(len(name) for name in names)
    print(f"\n{'':<{width + 7}} {'ms per simulated s (best)':^35}")
    print(f"{'scenario':<{width}} {'sim s':>6} {'wall: base':>11} {'current':>8} {'cpu: base':>10} {'current':>8} "
          f"{'ratio (best)':>13} {'ratio (median)':>15} {'cpu ratio':>10}  judged on")
    regressions, loaded = [], []
    for name in names:
        base = [r[name] for r in rounds["baseline"]]
        now = [r[name] for r in rounds["current"]]
        base_wall, now_wall = per_sim_second(base, "wall_s"), per_sim_second(now, "wall_s")
        ratio = min(now_wall) / min(base_wall)
        paired = statistics.median(n / b for n, b in zip(now_wall, base_wall))
        base_cpu, now_cpu = min(per_sim_second(base, "cpu_s")), min(per_sim_second(now, "cpu_s"))
        cpu = now_cpu / base_cpu
        busy = [side for side, runs in (("baseline", base), ("current", now)) if busy_machine(runs)]
        judged, figure = (cpu, "CPU") if busy else (ratio, "wall")
        print(f"{name:<{width}} {now[0]['sim_s']:>6g} {1e3 * min(base_wall):>11.2f} {1e3 * min(now_wall):>8.2f} "
              f"{1e3 * base_cpu:>10.2f} {1e3 * now_cpu:>8.2f} {ratio:>13.3f} {paired:>15.3f} {cpu:>10.3f}  {figure}")
        if busy:
            loaded.append(f"{name} ({', '.join(busy)})")
        if judged > 1.0 + limit:
            regressions.append(f"{name}: {figure} time per simulated second grew {judged - 1.0:+.1%} against "
                               f"{args.baseline} ({commit[:12]}), over the +{limit:.0%} allowed")
    if loaded:
        print(f"warning: the machine was busy (a side's fastest run took over {LOADED_WALL_OVER_CPU:g}x its CPU "
              f"time in wall time): {'; '.join(loaded)}; judged on CPU time there", file=sys.stderr)
    for line in regressions:
        print(f"SPEED REGRESSION: {line}", file=sys.stderr)
    if regressions:
        print(f"bench_speed_regression: {len(regressions)} scenario(s) slower than the baseline allows; "
              f"find the cause, or move the ref in bench/{BASELINE_FILE.name} with the figures", file=sys.stderr)
        return 1
    print(f"\nno scenario over +{limit:.0%}")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except BenchError as exc:
        print(f"bench_speed_regression: {exc}", file=sys.stderr)
        sys.exit(2)
    except KeyboardInterrupt:
        sys.exit(130)
