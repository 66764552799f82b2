"""The examples (examples/) and `testbed init` do what they say (issue 10, items 3 and 5).

Each example is a plug-in file and a scenario that names it. Its results are checked against
numbers computed here, independently of the example's own code, from the trace arrays:
the user's PD torque recomputed from the recorded estimate, the weighted pseudo-inverse's
h J(beta) beta' = H' with J written out from the rhombus geometry, the star tracker's output
against the true attitude N ticks earlier, the sweep script's table against API runs.
The commands of docs/controller.md, "Write your own controller", are run verbatim in an empty folder.

Fast tests run the scenarios shortened (--set sim.duration_s=...); the whole runs are slow.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import testbed
from testbed.cli import main
from testbed.math.quaternion import quat_angle, quat_conj, quat_from_axis_angle, quat_mul, rotation_vector
from testbed.systems.registry import make_plant

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
PD = EXAMPLES / "pd_steering.yaml"
STAR = EXAMPLES / "star_tracker.yaml"
# the checkout's virtual environment; a worktree without one runs the interpreter running the tests
VENV_BIN = ROOT / ".venv" / "bin" if (ROOT / ".venv" / "bin").is_dir() else Path(sys.executable).parent
H = 25.0  # rotor_momentum_nms of both example scenarios


def run(path: Path, *overrides: str) -> testbed.RunResult:
    return testbed.run(testbed.load(path, list(overrides)))


def rhombus_jacobian(beta: np.ndarray, alpha: float) -> np.ndarray:
    """dH/dbeta / h of SEEDS §004 eq. (18), written out here: column i = -sin b_i e_i + cos b_i s_i z,
    e = (c, s, 0), (-c, s, 0), (-c, -s, 0), (c, -s, 0), signs (+, +, -, -). beta (n, 4) -> (n, 3, 4)."""
    c, s = np.cos(alpha), np.sin(alpha)
    e = np.array([[c, s, 0.0], [-c, s, 0.0], [-c, -s, 0.0], [c, -s, 0.0]])
    turn = np.array([[0, 0, 1.0], [0, 0, 1.0], [0, 0, -1.0], [0, 0, -1.0]])
    columns = -np.sin(beta)[..., None] * e + np.cos(beta)[..., None] * turn  # (n, 4, 3)
    return np.swapaxes(columns, -1, -2)


def at_control_ticks(result, key: str, times: np.ndarray) -> np.ndarray:
    """`key`'s trace values at `times` (the trace samples every control tick in these scenarios)."""
    t, values = result.trace[key]
    index = np.searchsorted(t, times)
    assert np.allclose(t[index], times, rtol=0, atol=1e-9)
    return values[index]


# --- example 1: the user's quaternion PD law and weighted pseudo-inverse steering ----------------

@pytest.fixture(scope="module")
def pd_short():
    """The first 10 s of examples/pd_steering.yaml: the rate limit scales the command for 1.35 s."""
    scenario = testbed.load(PD, ["sim.duration_s=10"])
    return scenario, testbed.run(scenario)


def test_the_user_law_torque_is_the_quaternion_pd_formula(pd_short):
    scenario, result = pd_short
    law = scenario.stages["law"][1]
    plant = make_plant(scenario)
    plant.initialise(scenario.initial)
    inertia = plant.locked_inertia()  # the system's locked inertia at t = 0 (CMG masses included)
    assert inertia[0, 0] > 800 and abs(inertia[0, 1]) < 1e-9 * inertia[0, 0]
    wn, zeta = law.natural_frequency_rad_s, law.damping_ratio
    target = quat_mul(scenario.initial.quat, quat_from_axis_angle(np.asarray(law.axis), np.radians(law.angle_deg)))
    t, torque = result.trace["law/torque"]
    q = at_control_ticks(result, "estimator/quat", t)
    w = at_control_ticks(result, "estimator/omega", t)
    error = quat_mul(quat_conj(target), q)
    e = 2.0 * np.sign(error[:, :1]) * error[:, 1:]  # 2 vec(q_e), the short way
    expected = -(e * wn**2 + w * 2 * zeta * wn) @ inertia.T + np.cross(w, w @ inertia.T)
    assert len(t) == 200
    np.testing.assert_allclose(torque, expected, rtol=0, atol=1e-12 * np.abs(expected).max())
    # the attitude error it reports is the angle to the target
    _, angle = result.trace["law/error_angle"]
    np.testing.assert_allclose(angle[:, 0], np.degrees(quat_angle(error)), rtol=1e-12, atol=1e-12)


def test_the_weighted_pinv_delivers_the_wanted_torque_exactly_when_unsaturated(pd_short):
    scenario, result = pd_short
    allocator = scenario.stages["allocator"][1]
    t, rates = result.trace["allocator/gimbal_rates"]
    beta = at_control_ticks(result, "truth/gimbal_angle", t)      # the encoders, at the tick
    momentum = at_control_ticks(result, "truth/cmg_momentum", t)  # H(beta, Omega), body axes
    torque = at_control_ticks(result, "law/torque", t)
    omega = at_control_ticks(result, "estimator/omega", t)
    scale = at_control_ticks(result, "allocator/scale", t)[:, 0]
    delivered = at_control_ticks(result, "allocator/torque_delivered", t)
    J = rhombus_jacobian(beta, np.radians(scenario.model.alpha_deg))
    hdot = -(torque + np.cross(omega, momentum))                  # wanted H' = -(M + w x H)
    produced = H * np.einsum("nij,nj->ni", J, rates)              # h J beta'
    free = scale == 1.0
    assert 20 <= np.count_nonzero(~free) <= 40 and np.count_nonzero(free) >= 160
    # unsaturated: h J beta' = H' and the delivered torque is the law's, to 1e-9 N m
    assert np.max(np.abs(produced[free] - hdot[free])) < 1e-9
    assert np.max(np.abs(delivered[free] - torque[free])) < 1e-9
    # saturated: the same direction, scaled: h J beta' = k H'
    assert np.max(np.abs(produced[~free] - scale[~free, None] * hdot[~free])) < 1e-9
    np.testing.assert_allclose(delivered, -produced - np.cross(omega, momentum), rtol=0, atol=1e-9)
    # the weighted least norm: beta' = W J^T lambda, so W^-1 beta' is orthogonal to null(J)
    null = np.linalg.svd(J)[2][:, 3, :]                           # unit null vector of each J
    weighted = rates / np.asarray(allocator.weights)
    cosine = np.abs(np.sum(null * weighted, axis=1)) / np.linalg.norm(weighted, axis=1)
    assert np.max(cosine) < 1e-12
    # and the weight differs from the plain pseudo-inverse: gimbal 4 (weight 0.5) works less
    plain = np.einsum("nji,nj->ni", J, np.linalg.solve(J @ np.swapaxes(J, 1, 2), hdot[:, :, None] / H)[:, :, 0]) * scale[:, None]
    assert np.sum(np.abs(rates[:, 3])) < 0.9 * np.sum(np.abs(plain[:, 3]))


def test_the_weighted_pinv_respects_the_rate_limit_and_the_cluster_conserves_momentum(pd_short):
    scenario, result = pd_short
    limit = np.radians(scenario.stages["allocator"][1].beta_rate_max_deg_s)
    _, rates = result.trace["allocator/gimbal_rates"]
    _, scale = result.trace["allocator/scale"]
    assert np.max(np.abs(rates)) <= limit * (1 + 1e-12)
    assert np.max(np.abs(rates)) == pytest.approx(limit, rel=1e-12)  # it reached the limit
    assert scale.min() == pytest.approx(0.8005, abs=1e-4)              # measured 0.80046
    _, servo = result.trace["truth/gimbal_rate"]
    assert np.max(np.abs(servo)) <= limit * (1 + 1e-3)                 # the servos follow (7.999 deg/s)
    _, L = result.trace["truth/angular_momentum_world"]                # total momentum, world frame
    assert np.max(np.linalg.norm(L - L[0], axis=1)) < 1e-9 * 4 * H
    assert result.metrics["user_rate_limit_violations"] == 0
    assert result.metrics["user_min_scale"] == pytest.approx(scale.min(), rel=1e-15)


@pytest.mark.slow
def test_the_pd_steering_example_runs_via_the_api_and_the_cli(tmp_path, capsys):
    result = testbed.run(PD)
    assert result.status == "ok" and result.passed, result.checks
    m = result.metrics
    assert m["user_final_attitude_error_deg"] < 0.005           # measured 8.3e-4
    assert m["user_peak_gimbal_rate_deg_s"] == pytest.approx(8.0, rel=1e-9)
    assert m["user_rate_limit_violations"] == 0
    assert m["user_min_scale"] == pytest.approx(0.8005, abs=1e-4)
    assert 0.05 < m["user_torque_error_rel"] < 0.12             # measured 0.083: the scaled first 1.35 s
    assert m["momentum_drift_rel"] < 1e-11                      # measured 6e-13
    # the metric is the attitude of the trace's last sample against the target, recomputed
    law = testbed.load(PD).stages["law"][1]
    target = quat_from_axis_angle(np.asarray(law.axis), np.radians(law.angle_deg))
    _, q = result.trace["truth/quat"]
    assert m["user_final_attitude_error_deg"] == pytest.approx(
        np.degrees(quat_angle(quat_mul(quat_conj(target), q[-1]))), rel=1e-9)
    out = tmp_path / "pd.rrd"
    assert main(["run", str(PD), "--out", str(out)]) == 0
    assert "user_final_attitude_error_deg" in capsys.readouterr().out
    again = testbed.read(out)
    assert again.status == "ok" and again.metrics == pytest.approx(m, rel=1e-12)


# --- example 2: the user's star tracker with latency and noise ------------------------------------

def test_the_star_tracker_reports_the_truth_delayed_by_n_ticks():
    result = run(STAR, "sim.duration_s=5", "pipeline.sensor.attitude_noise_rad=0", "pipeline.sensor.rate_noise_rad_s=0")
    n = testbed.load(STAR).stages["sensor"][1].latency_ticks
    assert n == 2
    t, measured = result.trace["sensor/quat"]
    t_truth, truth = result.trace["truth/quat"]
    assert len(t) == 100 and np.array_equal(t, t_truth[:-1])     # one sample per control tick
    delayed = truth[np.maximum(np.arange(len(t)) - n, 0)]         # q(t_(k-N)); q(0) before that
    assert np.array_equal(measured, delayed)
    assert not np.array_equal(measured[n:], truth[n:-1])          # it did move: the delay matters
    _, omega = result.trace["sensor/omega"]
    _, omega_truth = result.trace["truth/omega"]
    assert np.array_equal(omega, omega_truth[:-1])                # the gyro has no latency


@pytest.mark.slow
def test_the_star_tracker_example_runs_its_noise_and_its_cost(tmp_path):
    result = testbed.run(STAR)
    assert result.status == "ok" and result.passed, result.checks
    sensor = testbed.load(STAR).stages["sensor"][1]
    t, measured = result.trace["sensor/quat"]
    _, truth = result.trace["truth/quat"]
    delayed = truth[np.maximum(np.arange(len(t)) - sensor.latency_ticks, 0)]
    noise = np.array([rotation_vector(quat_mul(quat_conj(d), m)) for d, m in zip(delayed, measured)])
    assert len(noise) == 1200
    # white noise of std sigma per axis: sample std within 10 % (2 % expected), mean within 4 sigma/sqrt(n)
    np.testing.assert_allclose(noise.std(axis=0), sensor.attitude_noise_rad, rtol=0.1)
    assert np.all(np.abs(noise.mean(axis=0)) < 4 * sensor.attitude_noise_rad / np.sqrt(len(noise)))
    _, omega = result.trace["sensor/omega"]
    _, omega_truth = result.trace["truth/omega"]
    np.testing.assert_allclose((omega - omega_truth[:-1]).std(axis=0), sensor.rate_noise_rad_s, rtol=0.1)
    # the cost of latency: the true attitude trails the program by about peak rate x latency
    _, program_omega = result.trace["law/program_omega"]
    lag_deg = np.degrees(np.max(np.linalg.norm(program_omega, axis=1))) * sensor.latency_ticks * 0.05
    assert result.metrics["user_true_tracking_error_deg"] == pytest.approx(lag_deg, rel=0.03)  # 0.2240 vs 0.2250
    assert result.metrics["max_tracking_error_deg"] < 0.5 * result.metrics["user_true_tracking_error_deg"]
    assert result.metrics["final_attitude_error_deg"] < 1e-3 and result.metrics["rate_limit_violations"] == 0
    # the CLI run of the same file: exit 0, and the same seed gives the same samples bit for bit
    out = tmp_path / "star.rrd"
    assert main(["run", str(STAR), "--out", str(out)]) == 0
    assert np.array_equal(testbed.read(out).trace["sensor/quat"][1], measured)


# --- example 3: the sweep script --------------------------------------------------------------------

def sweep_script(*argv: str) -> list[list[str]]:
    done = subprocess.run([sys.executable, str(EXAMPLES / "sweep_gain.py"), *argv], capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.strip().splitlines()
    return [line.split() for line in lines[1:]]  # header row, then one row per value


def test_the_sweep_script_prints_what_the_api_computes():
    rows = sweep_script("--set", "sim.duration_s=10", "--values", "0.1", "0.2")
    header, body = rows[0], rows[1:]
    assert header[:2] == ["natural_frequency_rad_s", "status"] and len(body) == 2
    for row in body:
        result = run(PD, "sim.duration_s=10", f"pipeline.law.natural_frequency_rad_s={row[0]}")
        assert row[1] == result.status == "ok"
        for name, cell in zip(header[2:], row[2:]):
            assert float(cell) == pytest.approx(result.metrics[name], rel=1e-5, abs=1e-300), name


@pytest.mark.slow
def test_the_default_sweep_shows_the_gain_trade_off():
    rows = sweep_script()
    header, body = rows[0], rows[1:]
    table = {float(r[0]): dict(zip(header[1:], r[1:])) for r in body}
    assert sorted(table) == [0.05, 0.075, 0.1, 0.15, 0.2]
    scale = [float(table[wn]["user_min_scale"]) for wn in sorted(table)]
    assert scale[:2] == [1.0, 1.0] and scale[2] < 1 and scale == sorted(scale, reverse=True)
    assert all(float(r["user_peak_gimbal_rate_deg_s"]) <= 8.0 + 1e-9 for r in table.values())
    result = run(PD, "pipeline.law.natural_frequency_rad_s=0.15")
    assert float(table[0.15]["user_final_attitude_error_deg"]) == pytest.approx(
        result.metrics["user_final_attitude_error_deg"], rel=1e-5)


# --- testbed init ---------------------------------------------------------------------------------

def test_init_writes_a_scenario_and_a_controller_that_run_as_they_are(tmp_path, capsys):
    folder = tmp_path / "mysat"
    assert main(["init", str(folder)]) == 0
    printed = capsys.readouterr().out
    assert sorted(p.name for p in folder.iterdir()) == ["my_controller.py", "my_scenario.yaml"]
    assert f"testbed run {folder.as_posix()}/my_scenario.yaml" in printed
    out = tmp_path / "x.rrd"
    # in this process only once: a stage name is registered once per process
    assert main(["run", str(folder / "my_scenario.yaml"), "--out", str(out), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["status"] == "ok" and all(c["passed"] for c in result["checks"])
    assert {c["name"] for c in result["checks"]} == {"final_omega_rad_s", "my_final_attitude_error_deg"}
    # the template law is the PD its comments describe: M = -I (kp e + kd w) + w x I w, I = diag(800, 1000, 1200)
    back = testbed.read(out)
    law = testbed.load(folder / "my_scenario.yaml").stages["law"][1]
    target, wn, zeta = np.asarray(law.target_quat), law.natural_frequency_rad_s, law.damping_ratio
    t, torque = back.trace["law/torque"]
    q, w = at_control_ticks(back, "estimator/quat", t), at_control_ticks(back, "estimator/omega", t)
    error = quat_mul(quat_conj(target), q)
    e = 2.0 * np.sign(error[:, :1]) * error[:, 1:]
    inertia = np.diag([800.0, 1000.0, 1200.0])
    expected = -(e * wn**2 + w * 2 * zeta * wn) @ inertia + np.cross(w, w @ inertia)
    np.testing.assert_allclose(torque, expected, rtol=0, atol=1e-9 * np.abs(expected).max())
    _, q_truth = back.trace["truth/quat"]
    final = np.degrees(quat_angle(quat_mul(quat_conj(target), q_truth[-1])))
    assert result["metrics"]["my_final_attitude_error_deg"] == pytest.approx(final, rel=1e-6, abs=1e-9)
    assert final < 0.01 and np.degrees(quat_angle(quat_mul(quat_conj(target), q_truth[0]))) > 25


def test_init_never_overwrites(tmp_path, capsys):
    folder = tmp_path / "taken"
    folder.mkdir()
    (folder / "notes.txt").write_text("mine")
    assert main(["init", str(folder)]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and "is not empty" in err and "never overwrites" in err
    assert sorted(p.name for p in folder.iterdir()) == ["notes.txt"]
    assert (folder / "notes.txt").read_text() == "mine"
    (tmp_path / "a_file").write_text("x")
    assert main(["init", str(tmp_path / "a_file")]) == 2
    assert "not a folder" in capsys.readouterr().err
    assert main(["init"]) == 2  # DIR is required
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["init", str(empty)]) == 0  # an empty folder is fine
    assert sorted(p.name for p in empty.iterdir()) == ["my_controller.py", "my_scenario.yaml"]
    assert main(["init", str(empty)]) == 2  # and a second time refused, the files untouched


# --- docs/controller.md: "Write your own controller", verbatim ---------------------------------

DOCS = ROOT / "docs"


def section_of(page: str, heading: str) -> str:
    """The text of docs/<page> under the heading `heading` (any level), up to the next heading
    of the same or a higher level; a `#` line inside a code block is no heading."""
    lines = (DOCS / page).read_text(encoding="utf-8").splitlines(keepends=True)
    level, kept, fence = None, [], False
    for line in lines:
        fence ^= line.startswith("```")
        title = re.match(r"(#+) (.*)\n", line) if not fence and not line.startswith("```") else None
        if title and level is not None and len(title.group(1)) <= level:
            break
        if level is not None:
            kept.append(line)
        elif title and title.group(2) == heading:
            level = len(title.group(1))
    assert level is not None, f"docs/{page} has no heading {heading!r}"
    return "".join(kept)


def docs_commands(page: str, heading: str) -> str:
    """The ```sh blocks under `heading` in docs/<page>."""
    blocks = re.findall(r"^```sh\n(.*?)^```", section_of(page, heading), re.M | re.S)
    assert blocks, f"no ```sh block under {heading!r} in docs/{page}"
    return "".join(blocks)


def test_the_docs_write_your_own_controller_commands_run_verbatim(tmp_path):
    script = docs_commands("controller.md", "Write your own controller")
    commands = [line.split("#")[0].strip() for line in script.splitlines() if line.split("#")[0].strip()]
    assert commands == ["testbed init mysat", "testbed run mysat/my_scenario.yaml"]
    env = dict(os.environ, PATH=os.pathsep.join([str(VENV_BIN), os.environ.get("PATH", "")]))
    done = subprocess.run(["bash", "-e", "-c", script], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "my_scenario: ok" in done.stdout and "FAIL" not in done.stdout
    assert (tmp_path / "runs" / "my_scenario.rrd").is_file()


@pytest.mark.slow
def test_the_docs_python_api_example_runs(tmp_path, monkeypatch, capsys):
    (code,) = re.findall(r"^```python\n(.*?)^```", section_of("api.md", "Python API"), re.M | re.S)
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "docs/api.md (Python API)", "exec"), {})
    assert capsys.readouterr().out.startswith("ok True 4.93")  # reorient_minimax's peak rate (its pin)
    assert (tmp_path / "minimax6.rrd").is_file()
