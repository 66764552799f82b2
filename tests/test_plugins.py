"""Plug-ins: a scenario's own stages from a file, a module or an installed package, registered
with the public decorators, and every way a plug-in can go wrong reported precisely (issue 10)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import testbed
from testbed.cli import main
from testbed.recording.trace_reader import read_rrd

INERTIA = np.diag([800.0, 1000.0, 1200.0])  # the satellite system's default

DAMPER = '''
from dataclasses import dataclass
import numpy as np
import testbed

@dataclass(kw_only=True)
class Params:
    gain_per_s: float = testbed.param(1.0, gt=0)

@testbed.stage("law", "{name}", Params)
class RateDamper:
    """M = -g I w: every body rate decays, |I w| exactly at rate g."""
    outputs = ("torque",)

    def __init__(self, params, ctx):
        self.k = params.gain_per_s * np.asarray(ctx.inertia)

    def torque(self, t, estimate):
        {body}
'''


def scenario_text(name: str, law: str, plugins: str, duration: float = 20.0, extra: str = "") -> str:
    return textwrap.dedent(f"""\
        name: {name}
        plugins: {plugins}
        model: {{system: satellite}}
        initial: {{omega_deg_s: [1, -2, 3]}}
        sim: {{duration_s: {duration}, dt_s: 0.01}}
        pipeline:
          sensor: {{type: ideal_attitude}}
          estimator: {{type: attitude}}
          law: {{type: {law}, gain_per_s: 0.5}}
          allocator: {{type: ideal_torque}}
        {extra}""")


def write_case(tmp_path, law_name: str, body: str, **kw):
    """A plug-in file beside its scenario; returns the scenario path."""
    (tmp_path / "laws.py").write_text(DAMPER.format(name=law_name, body=body))
    path = tmp_path / "case.yaml"
    path.write_text(scenario_text("case", law_name, "[laws.py]", **kw))
    return path


def unique(tmp_path, stem: str) -> str:
    return f"test.{stem}_{abs(hash(str(tmp_path))) % 10**8}"  # one process registers each name once


def test_a_plugin_law_from_a_file_runs_and_obeys_its_physics(tmp_path):
    law = unique(tmp_path, "damper")
    path = write_case(tmp_path, law, 'return {"torque": -self.k @ estimate["omega"]}')
    result = testbed.run(path)
    assert result.status == "ok"
    t, torque = result.trace["law/torque"]
    _, omega = result.trace["estimator/omega"]
    np.testing.assert_allclose(torque, -0.5 * omega @ INERTIA.T, rtol=1e-12, atol=1e-15)
    # gyroscopic torque is perpendicular to L = I w, so |L| decays at the gain: |L| = |L0| e^(-g t)
    # (the zero-order hold over 0.01 s makes the rate (1 - e^(-g dt))/dt, 0.25 % less)
    tt, w = result.trace["truth/omega"]
    fitted = -np.polyfit(tt, np.log(np.linalg.norm(w @ INERTIA, axis=1)), 1)[0]
    assert fitted == pytest.approx(0.5, rel=5e-3)


def test_a_plugin_module_name_and_a_namespaced_name(tmp_path, monkeypatch):
    law = unique(tmp_path, "slew")  # namespaced, even though a built-in "slew" exists
    package = tmp_path / "site"
    package.mkdir()
    module = f"mylab_laws_{abs(hash(str(tmp_path))) % 10**8}"
    (package / f"{module}.py").write_text(DAMPER.format(name=law, body='return {"torque": -self.k @ estimate["omega"]}'))
    monkeypatch.syspath_prepend(str(package))
    (tmp_path / "s.yaml").write_text(scenario_text("m", law, f"[{module}]"))
    assert testbed.run(tmp_path / "s.yaml").status == "ok"


def test_a_plugin_file_already_imported_is_not_registered_twice(tmp_path, monkeypatch):
    """`import my_laws`, then a run of a scenario that lists my_laws.py: the same file, so the
    law is the one already registered (it was refused as 'already registered ... give it a
    namespaced name'), and it still obeys its physics."""
    import importlib

    law = unique(tmp_path, "imported")
    module = f"my_laws_{abs(hash(str(tmp_path))) % 10**8}"
    (tmp_path / f"{module}.py").write_text(DAMPER.format(name=law, body='return {"torque": -self.k @ estimate["omega"]}'))
    monkeypatch.syspath_prepend(str(tmp_path))
    imported = importlib.import_module(module)
    (tmp_path / "s.yaml").write_text(scenario_text("twice", law, f"[{module}.py]"))
    result = testbed.run(tmp_path / "s.yaml")
    assert result.status == "ok", result.error
    t, torque = result.trace["law/torque"]
    _, omega = result.trace["estimator/omega"]
    np.testing.assert_allclose(torque, -0.5 * omega @ INERTIA.T, rtol=1e-12, atol=1e-15)
    from testbed.pipeline import STAGES
    assert STAGES["law"][law][1] is imported.RateDamper  # the class of the module imported first


@pytest.mark.parametrize("source, line, kind", [
    ("import numpy\n\nvalue = 1 / 0\n", 3, "ZeroDivisionError"),
    ("def broken(:\n    pass\n", 1, "SyntaxError"),
    ("import no_such_package_here\n", 1, "ModuleNotFoundError"),
])
def test_a_plugin_that_fails_to_import_is_exit_2_naming_file_and_line(tmp_path, capsys, source, line, kind):
    (tmp_path / "bad.py").write_text(source)
    (tmp_path / "s.yaml").write_text(scenario_text("bad", "slew", "[bad.py]"))
    out = tmp_path / "x.rrd"
    assert main(["run", str(tmp_path / "s.yaml"), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert err.startswith("error: plugins[0]:") and f"bad.py:{line}" in err and kind in err, err
    assert not out.exists()


def test_a_missing_plugin_file_or_module_is_exit_2(tmp_path, capsys):
    for plugins, words in (("[nowhere.py]", "no such plug-in file"), ("[no_such_module_x]", "no module named")):
        (tmp_path / "s.yaml").write_text(scenario_text("bad", "slew", plugins))
        assert main(["run", str(tmp_path / "s.yaml"), "--out", str(tmp_path / "x.rrd")]) == 2
        assert words in capsys.readouterr().err


def test_a_plugin_may_not_shadow_a_builtin(tmp_path, capsys):
    path = write_case(tmp_path, "slew", 'return {"torque": np.zeros(3)}')
    assert main(["run", str(path), "--out", str(tmp_path / "x.rrd")]) == 2
    err = capsys.readouterr().err
    assert "law 'slew' is already registered" in err and "namespaced" in err and "laws.py" in err
    # nothing of the refused plug-in stays registered: the built-in slew law still runs
    assert testbed.run("reorient_minimax", overrides=["sim.duration_s=1"]).status == "ok"


@pytest.mark.parametrize("body, words", [
    ('if t >= 1.0:\n            raise RuntimeError("sensor cable cut")\n        return {"torque": -self.k @ estimate["omega"]}',
     "RuntimeError: sensor cable cut"),
    ('return {"torque": np.full(3, np.nan) if t >= 1.0 else -self.k @ estimate["omega"]}',
     "key 'torque' is not finite"),
    ('return {"torque": np.zeros(4) if t >= 1.0 else -self.k @ estimate["omega"]}',
     "key 'torque' has shape (4,), expected (3,)"),
    ('return {} if t >= 1.0 else {"torque": -self.k @ estimate["omega"]}',
     "missing key 'torque'"),
])
def test_a_failing_stage_ends_the_run_as_error_with_its_trace(tmp_path, capsys, body, words):
    law = unique(tmp_path, "failing")
    path = write_case(tmp_path, law, body)
    _ends_as_error_at_1_s(tmp_path, capsys, law, path, words)


@pytest.mark.parametrize("body", [
    'return {"tork": np.zeros(3)} if t >= 1.0 else {"torque": -self.k @ estimate["omega"]}',
    'return {} if t >= 1.0 else {"torque": -self.k @ estimate["omega"]}',
])
def test_a_law_declaring_no_outputs_still_owes_its_torque(tmp_path, capsys, body):
    """The law interface's `torque` is required whatever the law declares (docs/controller.md):
    without it the allocator was left no demand, and the run passed with status ok on zero torque."""
    law = unique(tmp_path, "undeclared")
    path = write_case(tmp_path, law, body)
    laws = tmp_path / "laws.py"
    laws.write_text(laws.read_text().replace('    outputs = ("torque",)\n', ""))
    _ends_as_error_at_1_s(tmp_path, capsys, law, path, "missing key 'torque' (a law returns 'torque')")


def _ends_as_error_at_1_s(tmp_path, capsys, law, path, words):
    out = tmp_path / "x.rrd"
    assert main(["run", str(path), "--out", str(out), "--json"]) == 1
    result = json.loads(capsys.readouterr().out)
    assert result["status"] == "error"
    assert result["error"].startswith(f"stage law '{law}' failed at t = 1 s:") and words in result["error"], result["error"]
    info = read_rrd(out)  # the trace up to the last good tick is written
    assert info["result"]["status"] == "error"
    assert info["time_span_s"] == pytest.approx([0.0, 0.99])
    t, torque = testbed.read(out).trace["law/torque"]
    assert t[-1] == pytest.approx(0.99) and np.all(np.isfinite(torque))


@pytest.mark.slow
def test_an_installed_plugin_package_is_found_by_its_entry_point(tmp_path):
    """A distribution on the path that declares the entry-point group testbed.plugins."""
    site = tmp_path / "site"
    (site / "mylab_ep-0.1.dist-info").mkdir(parents=True)
    (site / "mylab_ep-0.1.dist-info" / "METADATA").write_text("Metadata-Version: 2.1\nName: mylab-ep\nVersion: 0.1\n")
    (site / "mylab_ep-0.1.dist-info" / "entry_points.txt").write_text("[testbed.plugins]\nlaws = mylab_ep\n")
    (site / "mylab_ep.py").write_text(DAMPER.format(name="mylab.damper", body='return {"torque": -self.k @ estimate["omega"]}'))
    (tmp_path / "s.yaml").write_text(scenario_text("ep", "mylab.damper", "[]", extra="checks: {final_omega_rad_s: {max: 1e-4}}"))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(site)] + sys.path))
    done = subprocess.run([sys.executable, "-m", "testbed", "run", "s.yaml", "--json", "--out", "x.rrd"],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["status"] == "ok"
