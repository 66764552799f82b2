"""Issue 39: every command cost about 1.5 s of CPU before it started, the same for `testbed list`
as for a run, because the parser imported the run's machinery (the runner, Rerun, SciPy, MuJoCo).
The measure here is what a fresh process has imported when the command is over (sys.modules),
not its time: a library that is not imported costs nothing, on any machine
(docs/validation.md "Start-up" gives the CPU times).
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

WATCHED = ("rerun", "scipy", "scipy.optimize", "mujoco", "pandas", "testbed.runner")
PROBE = ("import json, sys\nfrom testbed.cli import main\ntry:\n    code = main(sys.argv[1:])\n"
         "except SystemExit as exc:  # --help\n    code = exc.code\n"
         f"print(json.dumps([code, sorted(m for m in {WATCHED!r} if m in sys.modules)]), file=sys.stderr)\n")


def imported(*argv, cwd=None) -> tuple[int, set[str]]:
    """(exit status, the watched modules imported) of `testbed ARGV` in a fresh interpreter."""
    done = subprocess.run([sys.executable, "-c", PROBE, *argv], capture_output=True, text=True, timeout=120, cwd=cwd)
    code, modules = json.loads(done.stderr.strip().splitlines()[-1])
    return code, set(modules)


@pytest.mark.parametrize("argv", [("list",), ("run", "--help")])
def test_a_command_that_writes_no_trace_imports_none_of_the_run_machinery(argv):
    code, modules = imported(*argv)
    assert code == 0 and not modules, modules


def test_init_writes_its_files_without_the_run_machinery(tmp_path):
    code, modules = imported("init", str(tmp_path / "new"))
    assert code == 0 and (tmp_path / "new" / "my_scenario.yaml").is_file() and not modules, modules


@pytest.mark.parametrize("argv", [("describe", "system", "cmg_rhombus"), ("--help",)])
def test_describe_and_help_read_the_registries_without_rerun(argv):
    """The registries (and the subcommands system packages add) need every stage's module,
    MuJoCo and SciPy behind them, not Rerun nor the runner."""
    code, modules = imported(*argv)
    assert code == 0 and "rerun" not in modules and "testbed.runner" not in modules, modules


def test_a_traced_run_does_not_import_pandas_nor_the_optimisers(tmp_path):
    """pyarrow imported pandas (0.6 s of CPU) to convert the trace's result text; three stage
    modules imported scipy.optimize (0.2-0.4 s) at the top, for runs that never call it."""
    code, modules = imported("run", "gyrostat_free", "--set", "sim.duration_s=1", "--out", str(tmp_path / "r.rrd"))
    assert code == 0 and "rerun" in modules and "pandas" not in modules, modules
    # gyrostat_free's reference integrates with SciPy (which loads the optimisers); a wheel slew calls neither
    code, modules = imported("run", "reaction_wheel_slew", "--set", "sim.duration_s=1", "--set", "checks={}",
                             "--out", str(tmp_path / "w.rrd"))
    assert code == 0 and "rerun" in modules and "scipy.optimize" not in modules, modules


def test_pyarrow_still_makes_pandas_objects_after_a_trace_is_written():
    """What needs pandas asks for it again (pyarrow's Table.to_pandas), after rerun_sdk's import."""
    probe = ("import sys\nimport testbed.recording.rerun_sdk\nimport pyarrow as pa\nassert 'pandas' not in sys.modules\n"
             "frame = pa.table({'a': [1.5, 2.5]}).to_pandas()\nprint(float(frame['a'].sum()))\n")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == "4.0", done.stderr
