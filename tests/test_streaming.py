"""The trace as a stream: written chunk by chunk while the run goes, readable after a SIGKILL,
metrics from running reductions equal to the whole-history numpy expressions."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import yaml

from testbed.recorder import CHUNK_ROWS

ROOT = Path(__file__).resolve().parents[1]
KILL_AT_S = 60.0
TRACE_PERIOD_S = 0.01


def _testbed(*args, cwd: Path, timeout: float = 300) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "testbed", *map(str, args)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def killed_run(tmp_path_factory) -> tuple[Path, subprocess.CompletedProcess]:
    """A tumbling satellite whose law SIGKILLs its own process at t = KILL_AT_S (of 120 s): the
    kill comes at a known simulated time, after one chunk (CHUNK_ROWS samples) has been written."""
    folder = tmp_path_factory.mktemp("killed")
    (folder / "kill_self.py").write_text(textwrap.dedent(f'''\
        import os, signal
        import numpy as np
        import testbed


        @testbed.stage("law", "test.kill_self")
        class KillSelf:
            outputs = ("torque",)

            def __init__(self, params, ctx):
                pass

            def torque(self, t, estimate):
                if t >= {KILL_AT_S}:
                    os.kill(os.getpid(), signal.SIGKILL)
                return {{"torque": np.zeros(3)}}
        '''))
    scenario = {"name": "killed", "plugins": ["kill_self.py"],
                "model": {"system": "satellite", "inertia_kg_m2": [800, 1000, 1200]},
                "initial": {"omega_deg_s": [0.5, -0.3, 0.4]},
                "sim": {"duration_s": 120, "dt_s": 0.01, "control_period_s": 0.01, "trace_period_s": TRACE_PERIOD_S},
                "pipeline": {"sensor": {"type": "ideal_attitude"}, "estimator": {"type": "attitude"},
                             "law": {"type": "test.kill_self"}, "allocator": {"type": "ideal_torque"}}}
    (folder / "killed.yaml").write_text(yaml.safe_dump(scenario))
    done = _testbed("run", "killed.yaml", "--out", "out/killed.rrd", cwd=folder)
    return folder, done


def test_a_run_killed_with_sigkill_leaves_a_readable_partial_trace(killed_run):
    folder, done = killed_run
    assert done.returncode == -signal.SIGKILL, (done.returncode, done.stderr[-2000:])
    assert not (folder / "out" / "killed.rrd").exists()  # no finished trace: the rename never came
    partials = sorted((folder / "out").glob(".killed.rrd.*.partial"))
    assert len(partials) == 1, partials
    shown = _testbed("inspect", partials[0], "--json", cwd=folder)
    assert shown.returncode == 0, shown.stderr
    info = json.loads(shown.stdout)
    for entity in ("/truth/omega", "/truth/quat", "/law/torque", "/world/bus"):
        assert info["entities"].get(entity, 0) >= CHUNK_ROWS, (entity, info["entities"])
    # every whole chunk written before the kill is there, none after it: the samples up to the
    # last flush (a multiple of CHUNK_ROWS samples) before t = KILL_AT_S
    chunks = int(KILL_AT_S / TRACE_PERIOD_S) // CHUNK_ROWS
    assert chunks >= 1
    assert info["time_span_s"] == pytest.approx([0.0, (chunks * CHUNK_ROWS - 1) * TRACE_PERIOD_S], abs=1e-9)
    assert info["entities"]["/truth/omega"] == chunks * CHUNK_ROWS + 1  # + the series' static row
    result = info["result"]
    assert result["status"] == "error" and "did not finish" in result["error"]


def test_the_partial_trace_holds_the_true_samples(killed_run):
    """The signals read back from the killed run equal a complete run of the same scenario
    stopped before the kill, sample for sample."""
    import testbed
    from testbed.trace import read_signals

    folder, _ = killed_run
    partial = next((folder / "out").glob(".killed.rrd.*.partial"))
    t, omega = read_signals(partial)["truth/omega"]
    spec = yaml.safe_load((folder / "killed.yaml").read_text())
    spec["plugins"] = [str(folder / "kill_self.py")]
    spec["sim"]["duration_s"] = 50.0  # before the kill
    whole = testbed.run(spec)
    t_whole, omega_whole = whole.trace["truth/omega"]
    n = len(t)
    assert n == CHUNK_ROWS and np.array_equal(omega, omega_whole[:n])
    assert np.allclose(t, t_whole[:n], atol=1e-9)
