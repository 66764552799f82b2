"""Bad scenario input: one line naming the field and the reason, exit 2, no output file."""

import pytest

from testbed.cli import main
from testbed.errors import InputError
from testbed.scenario.loading import apply_override, load_scenario, parse

BASE = {
    "name": "t",
    "model": {"system": "gyrostat", "inertia_kg_m2": [800, 1000, 1200]},
    "sim": {"duration_s": 1.0, "dt_s": 0.01, "control_period_s": 0.1},
}


def _with(path: str, value):
    data = {k: (dict(v) if isinstance(v, dict) else v) for k, v in BASE.items()}
    apply_override(data, f"{path}={value}")
    return data


@pytest.mark.parametrize("path, value, field, words", [
    ("model.inertia_kg_m2", "[0, 1000, 1200]", "model.inertia_kg_m2", "> 0"),
    ("model.inertia_kg_m2", "[100, 100, 1200]", "model.inertia_kg_m2", "triangle"),
    ("model.inertia_kg_m2", "[1, 2]", "model.inertia_kg_m2", "3 elements"),
    ("model.rotor_axis", "[0, 0, 0]", "model.rotor_axis", "zero vector"),
    ("model.rotor_axis", "[1, 1, 0]", "model.rotor_axis", "unit vector"),
    ("model.mass_kg", "-3", "model.mass_kg", "> 0"),
    ("model.colour", "red", "model.colour", "unknown key"),
    ("model.system", "starship", "model.system", "unknown system"),
    ("sim.dt_s", "0", "sim.dt_s", "> 0"),
    ("sim.dt_s", "-0.01", "sim.dt_s", "> 0"),
    ("sim.duration_s", "-5", "sim.duration_s", "> 0"),
    ("sim.control_period_s", "0.015", "sim.control_period_s", "multiple of dt_s"),
    ("sim.trace_period_s", "0.15", "sim.trace_period_s", "multiple of control_period_s"),
    ("sim.integrator", "leapfrog", "sim.integrator", "one of"),
    ("sim.dt_s", "fast", "sim.dt_s", "must be a number"),
    ("initial.quat", "[1, 1, 0, 0]", "initial.quat", "unit quaternion"),
    ("initial.omega_deg_s", "[1, 2]", "initial.omega_deg_s", "3 elements"),
    ("pipeline.sensor.type", "crystal_ball", "pipeline.sensor.type", "unknown sensor"),
    ("pipeline.turbo", "{type: none}", "pipeline.turbo", "unknown slot"),
    ("reference.type", "oracle", "reference.type", "unknown reference"),
    ("checks.happiness", "{max: 1}", "checks.happiness", "no such metric"),
    ("checks.happiness", "{b: {max: 1}}", "checks.happiness", "no such metric"),  # the metric before its limits
    ("checks.momentum_drift_rel", "{max: fast}", "checks.momentum_drift_rel.max", "must be a number"),
    ("checks.momentum_drift_rel", "{}", "checks.momentum_drift_rel", "give max or min"),
    ("checks.momentum_drift_rel", "{max: 1e-9, typo: 2}", "checks.momentum_drift_rel.typo", "unknown key"),
])
def test_bad_field_is_refused_with_its_name(path, value, field, words):
    with pytest.raises(InputError) as info:
        parse(_with(path, value))
    assert info.value.field == field
    assert words in info.value.reason


def test_scientific_notation_without_dot_is_a_number():
    scenario = parse(_with("checks.momentum_drift_rel", "{max: 1e-9}"))
    assert scenario.checks["momentum_drift_rel"].max == 1e-9


def test_defaults_fill_the_control_and_trace_periods():
    scenario = parse({**BASE, "sim": {"duration_s": 1.0, "dt_s": 0.01}})
    assert scenario.sim.control_period_s == 0.01 and scenario.sim.trace_period_s == 0.01


def test_set_override_is_validated_like_the_file():
    scenario = load_scenario("gyrostat_free", ["sim.duration_s=2", "model.rotor_speed_rpm=3000"])
    assert scenario.sim.duration_s == 2.0 and scenario.model.rotor_speed_rpm == 3000.0
    with pytest.raises(InputError, match="sim.duration_s"):
        load_scenario("gyrostat_free", ["sim.duration_s=-2"])


@pytest.mark.parametrize("argv, field", [
    (["run", "gyrostat_free", "--set", "sim.dt_s=-1"], "sim.dt_s"),
    (["run", "gyrostat_free", "--set", "model.inertia_kg_m2=[1, 1, 5]"], "model.inertia_kg_m2"),
    (["run", "gyrostat_free", "--set", "nonsense"], "--set"),
    (["run", "no_such_scenario"], "scenario"),
    (["inspect", "missing.rrd"], "rrd"),
    (["frobnicate"], "usage"),
])
def test_cli_bad_input_exits_2_with_one_line_and_no_file(argv, field, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "x.rrd"
    if argv[0] == "run":
        argv = argv + ["--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"error: {field}")
    assert "Traceback" not in err
    assert list(tmp_path.iterdir()) == []
