"""Monte Carlo dispersions (issue 12): each distribution against its own formulas, per-case
seeds, redraws of refused values, values read back from the built model and stages, `--case N`
bit for bit, and bad input refused before anything runs."""

from __future__ import annotations

import copy
import json
import math
import subprocess
import sys

import numpy as np
import pytest
import yaml

from campaign_cases import same_cells, spinup
from testbed.cli import main
from testbed.campaign.dispersions import angle_deg
from testbed.errors import InputError
from testbed.campaign.cases import MAX_REFUSED_SHARE, expand
from testbed.campaign.rows import run_case, run_cases
from testbed.campaign.spec import MAX_CASES, assignments, case_seed, field_generator, load_spec

# The Lebedev one-gyro spin-up on a rigid bus, 20 s (tests/campaign_cases.py).
GYRO = spinup("gyro_campaign", {"final_omega_rad_s": {"max": 1.0}})
# Every kind of dispersion, each on a field that is read back from the compiled model or the
# constructed stage.
EVERY_KIND = {
    "model.mass_kg": {"normal": [77000, 3000]},
    "model.inertia_kg_m2": {"truncated_normal": [0, 0.02, -0.03, 0.03], "relative": True},
    "initial.omega_deg_s": {"uniform": [-0.1, 0.1], "offset": True},
    "pipeline.sensor.noise_sigma_rad_s": {"log_uniform": [1e-8, 1e-6]},
    "pipeline.sensor.seed": {"integer": [0, 4294967295]},
    "pipeline.sensor.axis": {"misalignment_deg": 0.5},
    "sim.integrator": {"choice": ["RK4", "Euler"]},
}
# A rest-to-rest slew of the same bus about a random axis (testbed/guidance/slew.py).
SLEW = {
    "name": "slew_campaign",
    "model": {"system": "satellite", "inertia_kg_m2": [800, 1000, 1200]},
    "sim": {"duration_s": 10, "dt_s": 0.01, "control_period_s": 0.05},
    "pipeline": {"sensor": {"type": "ideal_attitude"}, "estimator": {"type": "attitude"},
                 "law": {"type": "slew", "axis": [1, 0, 0], "angle_deg": 30, "duration_s": 8},
                 "allocator": {"type": "ideal_torque"}},
    "sweep": {"seed": 5, "samples": 4, "dispersions": {
        "pipeline.law.axis": {"uniform_direction": True},
        "pipeline.law.angle_deg": {"uniform": [30, 150]},
        "pipeline.law.duration_s": {"log_uniform": [6, 9]}}},
}


def campaign(base: dict, dispersions: dict, samples: int, seed: int = 1, **extra) -> dict:
    return copy.deepcopy(base) | {"sweep": {"seed": seed, "samples": samples, "dispersions": dispersions, **extra}}


def draws(dispersion: dict, n: int, nominal=None, seed: int = 3) -> list:
    """n independent draws of one dispersion, as the cases of a campaign make them."""
    spec = load_spec({"dispersions": {"x": dispersion}, "samples": n, "seed": seed})
    return [values["x"] for values in assignments(spec, lambda path: copy.deepcopy(nominal))]


def normal_cdf(x: float) -> float:
    return 0.5 * (1.0 + math.erf(x / math.sqrt(2.0)))


# --- each distribution against its own formulas -------------------------------------------------

def test_normal_and_truncated_normal_moments():
    x = np.array(draws({"normal": [2.0, 0.5]}, 4000))
    assert abs(x.mean() - 2.0) < 4 * 0.5 / math.sqrt(4000) and abs(x.std() / 0.5 - 1) < 0.05
    # truncated to [mean - sigma, mean + 2 sigma]: mean mu + sigma (phi(a) - phi(b)) / (Phi(b) - Phi(a))
    x = np.array(draws({"truncated_normal": [1.0, 2.0, -1.0, 5.0]}, 4000))
    a, b = -1.0, 2.0
    phi = lambda z: math.exp(-z * z / 2) / math.sqrt(2 * math.pi)  # noqa: E731
    mean = 1.0 + 2.0 * (phi(a) - phi(b)) / (normal_cdf(b) - normal_cdf(a))
    assert x.min() >= -1.0 and x.max() <= 5.0
    assert abs(x.mean() - mean) < 4 * 2.0 / math.sqrt(4000)


def test_uniform_log_uniform_integer_and_choice():
    x = np.array(draws({"uniform": [-1.0, 3.0]}, 4000))
    assert x.min() >= -1 and x.max() < 3 and abs(x.mean() - 1.0) < 4 * (4 / math.sqrt(12)) / math.sqrt(4000)
    x = np.log10(draws({"log_uniform": [0.01, 100.0]}, 4000))
    assert x.min() >= -2 and x.max() < 2 and abs(x.mean()) < 4 * (4 / math.sqrt(12)) / math.sqrt(4000)
    x = draws({"integer": [2, 4]}, 3000)
    assert sorted(set(x)) == [2, 3, 4] and all(isinstance(v, int) for v in x)
    assert all(abs(x.count(v) - 1000) < 4 * math.sqrt(3000 * 2 / 9) for v in (2, 3, 4))
    x = draws({"choice": ["pinv", {"type": "minimax"}]}, 2000)
    assert abs(x.count("pinv") - 1000) < 4 * math.sqrt(500) and x.count({"type": "minimax"}) == 2000 - x.count("pinv")


def test_vector_forms_relative_offset_and_per_component():
    nominal = [800.0, 1000.0, 1200.0]
    x = np.array(draws({"uniform": [-0.05, 0.05], "relative": True}, 3000, nominal))
    ratio = x / nominal
    assert x.shape == (3000, 3) and ratio.min() >= 0.95 and ratio.max() < 1.05
    assert abs(np.corrcoef(ratio.T)[0, 1]) < 0.08  # the axes are drawn independently
    x = np.array(draws({"normal": [0.0, 0.1], "offset": True}, 3000, [1.0, -2.0]))
    assert np.allclose(x.mean(axis=0), [1.0, -2.0], atol=4 * 0.1 / math.sqrt(3000))
    x = np.array(draws({"uniform": [-0.5, 0.5], "size": 3}, 10))
    assert x.shape == (10, 3)


def test_misalignment_turns_the_axis_by_a_normal_angle_in_a_random_direction():
    """The angle to the nominal axis is |theta|, theta ~ N(0, sigma): half-normal, mean sigma sqrt(2/pi),
    P(|theta| < sigma) = 68.3 %; the turn goes in every direction around the axis alike."""
    nominal = [0.0, 0.6, 0.8]
    x = np.array(draws({"misalignment_deg": 0.5}, 4000, nominal))
    assert np.allclose(np.linalg.norm(x, axis=1), 1.0, rtol=0, atol=1e-15)
    angles = np.array([angle_deg(v, nominal) for v in x])
    assert abs(angles.mean() / (0.5 * math.sqrt(2 / math.pi)) - 1) < 0.04
    assert abs(np.mean(angles < 0.5) - (2 * normal_cdf(1.0) - 1)) < 0.03
    # along the axis: cos(theta), whose mean is exp(-sigma^2 / 2) for theta ~ N(0, sigma)
    sigma = math.radians(0.5)
    assert np.mean(x @ nominal) == pytest.approx(math.exp(-sigma**2 / 2), abs=2e-6)
    # across it: no preferred direction (the sideways parts average out to 0 within 4 sigma / sqrt(n))
    sideways = x - np.outer(x @ nominal, nominal)
    assert np.allclose(sideways.mean(axis=0), 0, atol=4 * sigma / math.sqrt(4000))


def test_uniform_direction_covers_the_sphere_evenly():
    x = np.array(draws({"uniform_direction": True}, 4000))
    assert np.allclose(np.linalg.norm(x, axis=1), 1.0, rtol=0, atol=1e-15)
    # uniform on the sphere: each component uniform on [-1, 1] (Archimedes), mean 0, variance 1/3
    assert np.allclose(x.mean(axis=0), 0, atol=4 * math.sqrt(1 / 3 / 4000))
    assert np.allclose(x.var(axis=0), 1 / 3, rtol=0.06)
    assert abs(np.mean(np.abs(x[:, 2]) < 0.5) - 0.5) < 0.03


# --- seeds ---------------------------------------------------------------------------------

def test_each_case_is_made_from_its_own_seed():
    data = campaign(GYRO, EVERY_KIND, 6, seed=11)
    cases = expand(data)
    assert [c.seed for c in cases] == [case_seed(11, i) for i in range(6)] and len({c.seed for c in cases}) == 6
    alone = expand(data, indices=[4])[0]
    assert alone.values == cases[4].values and alone.seed == cases[4].seed
    # a field draws from its own generator: the case seed spawned at its path
    rng = field_generator(cases[2].seed, "model.mass_kg")
    assert cases[2].values["model.mass_kg"] == rng.normal(77000, 3000)
    # adding a field leaves the other fields' draws unchanged; another campaign seed changes them
    more = expand(campaign(GYRO, EVERY_KIND | {"pipeline.sensor.bias_rad_s": {"normal": [0, 1e-6]}}, 6, seed=11))
    assert all(m.values[k] == c.values[k] for m, c in zip(more, cases) for k in EVERY_KIND)
    other = expand(campaign(GYRO, EVERY_KIND, 6, seed=12))
    assert all(o.values["model.mass_kg"] != c.values["model.mass_kg"] for o, c in zip(other, cases))


def test_random_block_keeps_its_one_stream_and_grids_combine_with_dispersions():
    data = copy.deepcopy(GYRO) | {"sweep": {"seed": 3, "samples": 2, "grid": {"sim.integrator": ["RK4", "Euler"]},
                                            "random": {"model.mass_kg": {"uniform": [7e4, 8e4]}},
                                            "dispersions": {"pipeline.sensor.seed": {"integer": [0, 99]}}}}
    cases = expand(data)
    stream = np.random.default_rng(3).uniform(7e4, 8e4, 4)
    assert [c.values["sim.integrator"] for c in cases] == ["RK4", "RK4", "Euler", "Euler"]
    assert [c.values["model.mass_kg"] for c in cases] == list(stream)
    # sample j draws the same dispersions at every grid point (its seed is case_seed(3, j))
    assert [c.seed for c in cases] == [case_seed(3, j) for j in (0, 1, 0, 1)] and cases[0].seed != cases[1].seed
    assert [c.values["pipeline.sensor.seed"] for c in cases] == [
        int(field_generator(case_seed(3, j), "pipeline.sensor.seed").integers(0, 99, endpoint=True)) for j in (0, 1, 0, 1)]


# --- refused draws ---------------------------------------------------------------------------------

def test_a_refused_draw_is_drawn_again_from_its_own_generator():
    """Inertia (1, 1, 1.85) kg m^2 +-5 % per axis: 0.7 % of the draws break the triangle
    inequality I3 <= I1 + I2 (measured over 2e5 draws); each is replaced by the field's next draw."""
    dispersion = {"uniform": [-0.05, 0.05], "relative": True}
    data = campaign(GYRO, {"model.inertia_kg_m2": dispersion}, 600, seed=4)
    data["model"]["inertia_kg_m2"] = [1.0, 1.0, 1.85]
    first = assignments(load_spec(data["sweep"]), lambda path: [1.0, 1.0, 1.85])
    cases = expand(data)
    broken = [i for i, v in enumerate(first) if v["model.inertia_kg_m2"][2] > sum(v["model.inertia_kg_m2"][:2])]
    assert 0 < len(broken) <= MAX_REFUSED_SHARE * 600  # this seed meets some, within the allowed share
    for i, case in enumerate(cases):
        inertia = case.values["model.inertia_kg_m2"]
        assert inertia[2] <= inertia[0] + inertia[1]
        if i not in broken:
            assert inertia == first[i]["model.inertia_kg_m2"]
        else:  # the field generator's next valid draw
            rng = field_generator(case.seed, "model.inertia_kg_m2")
            while True:
                again = (np.array([1.0, 1.0, 1.85]) * (1 + rng.uniform(-0.05, 0.05, 3))).tolist()
                if again[2] <= again[0] + again[1]:
                    break
            assert inertia == again
    assert expand(data, indices=[broken[0]])[0].values == cases[broken[0]].values


def test_too_many_refused_draws_refuse_the_campaign(tmp_path, capsys):
    """(1, 1, 1.95) +-5 %: about 26 % of the draws break the triangle inequality."""
    data = campaign(GYRO, {"model.inertia_kg_m2": {"uniform": [-0.05, 0.05], "relative": True}}, 50)
    data["model"]["inertia_kg_m2"] = [1.0, 1.0, 1.95]
    out = tmp_path / "out"
    assert main(["sweep", write(tmp_path, data), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: sweep.dispersions.model.inertia_kg_m2: ")
    assert "triangle inequality" in err[0] and not out.exists()


# --- read back -------------------------------------------------------------------------------------

def applied_of(row: dict, path: str):
    """The read-back value of `path` in a row (one column per component of a vector)."""
    if f"applied:{path}" in row:
        return row[f"applied:{path}"]
    return [row[f"applied:{path}[{i}]"] for i in range(3)]


@pytest.mark.parametrize("data", [campaign(GYRO, EVERY_KIND, 4), SLEW], ids=["gyro", "slew"])
def test_every_dispersion_type_reaches_the_model_and_the_stages(data):
    """Each row's read-back values (the compiled model's bus mass and inertia, the initial rate
    in MuJoCo's state, the timestep's integrator, the gyro's axis and its noise generator's
    seed, the slew program's axis, angle and duration) equal the drawn values."""
    from testbed.campaign.applied_values import applied_values
    from testbed.runner import prepare
    from testbed.scenario.loading import parse

    cases = expand(data)
    rows = run_cases(cases, workers=1)
    for case, row in zip(cases, rows):
        assert row["status"] == "ok", row["error"]
        for path, value in case.values.items():
            got = applied_of(row, path)
            assert np.allclose(got, value, rtol=1e-12, atol=0) if not isinstance(value, str) else got == value, path
        scenario = parse(case.data)
        plant, pipeline, _ = prepare(scenario)
        sources = {path: source for path, (_, source) in
                   applied_values(case.values, scenario, plant, pipeline.stages()).items()}
        assert set(sources.values()) <= {"model", "stage"}, sources
    if data is SLEW:
        assert {round(r["applied:pipeline.law.angle_deg"]) for r in rows} != {30}


def test_a_value_that_does_not_reach_the_model_is_refused(tmp_path):
    """A plug-in system whose build ignores model.inertia_kg_m2 (the MJCF's own inertia stays):
    the compiled model's bus inertia differs from the drawn one, so the campaign is refused."""
    (tmp_path / "forgetful.py").write_text('''
from dataclasses import dataclass
from testbed.systems.free_bus import FreeBus
from testbed.plant import Plant
from testbed.scenario.schema import param
from testbed.scenario.shipped_files import load_spec
from testbed.systems.registry import system


@dataclass(kw_only=True)
class Params:
    system: str = "forgetful_bus"
    inertia_kg_m2: list[float] = param([800.0, 1000.0, 1200.0], length=3)


@system("forgetful_bus", Params)
def make_plant(params, sim):
    return Plant(FreeBus(load_spec("satellite.xml", sim.dt_s, sim.integrator).compile()))
''')
    data = {"name": "forgetful", "plugins": ["forgetful.py"], "model": {"system": "forgetful_bus"},
            "sim": {"duration_s": 1, "dt_s": 0.01},
            "sweep": {"samples": 2, "dispersions": {"model.inertia_kg_m2": {"normal": [1000, 10], "size": 3}}}}
    out = tmp_path / "out"
    # in its own process: the plug-in's system stays out of this one's registries
    done = subprocess.run([sys.executable, "-m", "testbed", "sweep", write(tmp_path, data), "--out", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and done.stdout == ""
    assert len(done.stderr.splitlines()) == 1
    assert done.stderr.startswith("error: sweep.dispersions.model.inertia_kg_m2: case 0: ")
    assert "does not reach the simulation" in done.stderr and "the compiled model has" in done.stderr
    assert not out.exists()


# --- --case N ------------------------------------------------------------------------------------

def test_case_n_reruns_its_row_bit_for_bit_and_writes_its_trace(tmp_path, capsys):
    data = campaign(GYRO, EVERY_KIND, 3, seed=9)
    path = write(tmp_path, data)
    out = tmp_path / "out"
    rows = run_cases(expand(data, path), workers=1)
    assert main(["sweep", path, "--case", "2", "--out", str(out), "--json"]) == 0
    again = json.loads(capsys.readouterr().out)
    assert same_cells(again, rows[2])
    assert (out / "case0002.rrd").is_file() and list(out.iterdir()) == [out / "case0002.rrd"]
    assert main(["inspect", str(out / "case0002.rrd"), "--json"]) == 0
    stored = json.loads(capsys.readouterr().out)["result"]["metrics"]
    assert same_cells(stored, {k: rows[2][k] for k in stored})
    assert main(["sweep", path, "--case", "3", "--out", str(out)]) == 2
    assert "--case: must be a case number 0 ... 2, got 3" in capsys.readouterr().err



# --- bad input -------------------------------------------------------------------------------------

def write(tmp_path, data, name="c.yaml") -> str:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return str(path)


@pytest.mark.parametrize("sweep, field", [
    ({"samples": 2, "dispersions": {"model.bogus": {"normal": [1, 1]}}}, "sweep.dispersions.model.bogus"),
    ({"samples": 2, "dispersions": {"pipeline.sensor.axes": {"misalignment_deg": 1}}},
     "sweep.dispersions.pipeline.sensor.axes"),
    ({"samples": 2, "dispersions": {"model.mass_kg": {"normal": [1, -1]}}}, "sweep.dispersions.model.mass_kg.normal"),
    ({"samples": 2, "dispersions": {"model.mass_kg": {"truncated_normal": [1, 0, 0, 2]}}},
     "sweep.dispersions.model.mass_kg.truncated_normal"),
    ({"samples": 2, "dispersions": {"model.mass_kg": {"uniform": [2, 2]}}}, "sweep.dispersions.model.mass_kg.uniform"),
    ({"samples": 2, "dispersions": {"model.mass_kg": {"log_uniform": [5, 1]}}},
     "sweep.dispersions.model.mass_kg.log_uniform"),
    ({"samples": 2, "dispersions": {"model.mass_kg": {"log_uniform": [0, 1]}}},
     "sweep.dispersions.model.mass_kg.log_uniform[0]"),
    ({"samples": 2, "dispersions": {"pipeline.sensor.seed": {"integer": [3, 1]}}},
     "sweep.dispersions.pipeline.sensor.seed.integer"),
    ({"samples": 2, "dispersions": {"sim.integrator": {"choice": []}}}, "sweep.dispersions.sim.integrator.choice"),
    ({"samples": 2, "dispersions": {"model.mass_kg": {"normal": [1, 1], "uniform": [0, 1]}}},
     "sweep.dispersions.model.mass_kg"),
    ({"samples": 2, "dispersions": {"model.mass_kg": {"choice": [1, 2], "relative": True}}},
     "sweep.dispersions.model.mass_kg.relative"),
    ({"samples": 0, "dispersions": {"model.mass_kg": {"normal": [1, 1]}}}, "sweep.samples"),
    ({"samples": -3, "dispersions": {"model.mass_kg": {"normal": [1, 1]}}}, "sweep.samples"),
    ({"samples": MAX_CASES + 1, "dispersions": {"model.mass_kg": {"normal": [1, 1]}}}, "sweep"),
    ({"samples": 2, "dispersions": {"model.mass_kg": {"normal": [77000, 1e6]}}}, "sweep.dispersions.model.mass_kg"),
    ({"samples": 2, "grid": {"model.mass_kg": [1]}, "dispersions": {"model.mass_kg": {"normal": [1, 1]}}},
     "sweep.dispersions.model.mass_kg"),
])
def test_bad_campaigns_are_one_line_exit_2_before_anything_runs(sweep, field, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["sweep", write(tmp_path, copy.deepcopy(GYRO) | {"sweep": sweep}), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: {field}:"), err
    assert not out.exists()


def test_an_output_folder_that_cannot_be_written_is_refused_first(tmp_path, capsys):
    (tmp_path / "file").write_text("x")
    path = write(tmp_path, campaign(GYRO, {"model.mass_kg": {"normal": [77000, 10]}}, 2))
    assert main(["sweep", path, "--out", str(tmp_path / "file" / "out")]) == 2
    assert capsys.readouterr().err.startswith("error: --out:")
    assert main(["sweep", path, "--out", str(tmp_path / "file")]) == 2
    assert "is a file" in capsys.readouterr().err


@pytest.mark.parametrize("name, count", [("lebedev_spinup_campaign", 200), ("reorient_campaign", 200)])
def test_the_shipped_campaigns_build_and_read_back(name, count):
    """The campaigns of docs/campaigns.md: their case count, and a few cases each built as they will run,
    every dispersed value found again in the built model and stages."""
    from testbed.cli.campaign import load_cases

    _, data, cases = load_cases(name, [], [0, count // 2 + 1, count - 1])
    assert load_spec(data["sweep"]).count == count
    for case in cases:
        assert {source for _, source in case.prepared["applied"].values()} <= {"model", "stage"}


def test_a_numeric_dispersion_on_an_empty_list_field_is_refused_not_drawn_empty():
    """An empty nominal list gave len 0 components: every case drew [] and nothing was dispersed."""
    with pytest.raises(InputError) as refused:
        draws({"uniform": [0.0, 1.0]}, 2, [])
    assert refused.value.field == "sweep.dispersions.x" and "give size: N" in refused.value.reason
    assert np.array(draws({"uniform": [0.0, 1.0], "size": 2}, 5, [])).shape == (5, 2)
