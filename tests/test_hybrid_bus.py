"""A hybrid bus: a CMG cluster and reaction wheels on one bus (cmg_cluster with `model.wheels`, the
allocator hybrid_split; docs/theory/reaction-wheels.md, "Hybrid bus")."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from coast_cases import Initial, coast_drift
from testbed.cli import main
from testbed.runner import run_scenario
from testbed.scenario.loading import load_mapping, load_scenario, parse
from testbed.scenario.schema import load
from testbed.systems.cmg_cluster.hybrid_allocator import fine_part, isotropic_wheel_torque
from testbed.systems.cmg_cluster.hybrid_plant import HybridPlant
from testbed.systems.cmg_cluster.model import CmgClusterParams, build
from testbed.systems.cmg_cluster.reduced_model import CmgMassModel, reduced_cmg_segment
from testbed.systems.reaction_wheels.model import RPM

TUMBLE = (0.03, -0.02, 0.025)
MODEL = {"array": {"preset": "pyramid"}, "inertia_kg_m2": [300.0, 360.0, 280.0],
         "products_of_inertia_kg_m2": [12.0, -8.0, 5.0], "rotor_momentum_nms": 10.0,
         "servo_model": "feedforward", "servo_natural_frequency_rad_s": 5.0,
         "wheels": {"array": "nasa_standard", "wheel_speeds_rpm": [1500, -2500, 3000, 800]}}


def hybrid_plant(model: dict = MODEL, dt: float = 0.01, omega=TUMBLE) -> HybridPlant:
    params = load(CmgClusterParams, copy.deepcopy(model), "model")
    plant = HybridPlant(build(params, dt), params, 0.05)
    plant.initialise(Initial(omega))
    return plant


def test_the_wheels_join_the_cluster_on_one_bus_at_their_speeds():
    """The compiled model holds the 4 CMGs and the 4 wheels; the wheels start at the speeds asked,
    and the locked inertia (MuJoCo's mass matrix) is the hand sum of the reduced model's mass
    model, which adds each body's own inertia and its parallel-axis term (a second method):
    agreement to round-off of the inertia (1e-12 relative)."""
    plant = hybrid_plant()
    assert plant.wheels.array.count == 4 and plant.bus.units == 4
    assert np.allclose(plant.wheels.rates, np.array([1500, -2500, 3000, 800]) * RPM, rtol=1e-15)
    mass = CmgMassModel.from_model(plant.model)
    assert mass.has_wheels and np.allclose(mass.wheel_axes[3], np.ones(3) / np.sqrt(3.0), atol=1e-15)
    by_hand = mass.system_inertia(plant.bus.gimbal_angles(plant.data))
    assert np.max(np.abs(plant.locked_inertia() - by_hand)) < 1e-12 * np.max(np.abs(by_hand))


def test_momentum_is_conserved_in_a_coast_with_rotors_and_wheels_spinning():
    """Total momentum (bus, gimbals, rotors, wheels) about the CoM, world frame, over 20 s of a tumbling
    hybrid bus, gimbals held by their servos: internal torques only, so L is conserved up to RK4's
    truncation, which the CMGs set (the same bus without wheels drifts as much: 9e-9 of |L| at
    dt 0.01 s, 5e-9 with them). At dt 0.002 s: measured 8.4e-12 of |L|, falling as dt^4 (625x from
    0.01 s); band 1e-10. A wheel whose reaction missed the bus would show its 0.02 x 314 = 6 N m s."""
    plant = hybrid_plant(dt=0.002)
    start = plant.angular_momentum_world()
    assert coast_drift(plant, 200, 50) <= 1e-10 * np.linalg.norm(start)


def test_the_body_rate_is_the_reduced_models_with_wheels_and_gimbals_moving():
    """Constant wheel torques and gimbal rates on a tumbling hybrid bus: MuJoCo's body rate against the
    reduced model L_b' = -w x L_b, w = I_sys(b)^-1 (L_b - H_int) (DOP853 with the recorded gimbal,
    rotor and wheel histories as given inputs; the wheels' Jw Omega a in H_int). RK4 at 0.01 s and the
    interpolated servo start: measured 2.5e-10 rad/s over 4 s, band 1e-9 rad/s (3e-8 of the rates).
    Without the wheels' term the same model misses by the wheels' momentum change over I: > 1e-4 rad/s."""
    plant = hybrid_plant()
    torques, rates = np.array([0.1, -0.08, 0.12, -0.05]), np.radians([2.0, -1.5, 1.0, 3.0])
    plant.apply({"wheel_torques": torques, "gimbal_rates": rates})
    rows = {key: [] for key in ("t", "omega", "beta", "beta_rate", "rotor", "wheel")}

    def sample():
        truth = plant.truth()
        rows["t"].append(plant.data.time)
        rows["omega"].append(plant.omega())
        rows["beta"].append(truth["gimbal_angle"])
        rows["beta_rate"].append(truth["gimbal_rate"])
        rows["rotor"].append(truth["rotor_rate"])
        rows["wheel"].append(truth["wheel_rate"])

    sample()
    for _ in range(80):
        plant.step(5)
        sample()
    h = {key: np.array(value) for key, value in rows.items()}
    mass = CmgMassModel.from_model(plant.model)
    omega, _ = reduced_cmg_segment(mass, h["t"], h["beta"], h["beta_rate"], h["rotor"], h["t"], omega0=h["omega"][0],
                                   wheel_rate=h["wheel"])
    assert np.max(np.abs(omega - h["omega"])) < 1e-9
    without, _ = reduced_cmg_segment(mass, h["t"], h["beta"], h["beta_rate"], h["rotor"], h["t"], omega0=h["omega"][0])
    assert np.max(np.abs(without - h["omega"])) > 1e-4
    assert np.linalg.norm(h["omega"][-1] - h["omega"][0]) > 1e-3  # the torques did turn the bus


def test_the_wheels_share_is_the_closed_form():
    """tau_f of (HY-2): for the 4-wheel pyramid at 54.74 deg A A^T = (4/3) 1, so A^+ = (3/4) A^T and
    tau_f = (4/3) u_max; for three orthogonal wheels A^+ = 1 and tau_f is the weakest motor's; for the
    NASA standard array the rows of A^+ by hand (below). (HY-1) keeps the direction. Exact algebra:
    round-off bands."""
    from testbed.systems.reaction_wheels.wheel_array import nasa_standard_axes, pyramid_axes
    skew = np.degrees(np.arccos(1.0 / np.sqrt(3.0)))
    assert isotropic_wheel_torque(np.linalg.pinv(pyramid_axes(skew).T), np.full(4, 0.2)) == pytest.approx(0.8 / 3, rel=1e-14)
    assert isotropic_wheel_torque(np.eye(3), np.array([0.3, 0.1, 0.2])) == pytest.approx(0.1, rel=1e-15)
    # NASA standard: A A^T = 1 + (1/3) 1 1^T; its inverse is 1 - (1/6) 1 1^T, so (A^+)_x = (5, -1, -1)/6 and
    # (A^+)_4 = (1 1 1)/(2 sqrt 3): norms sqrt(27)/6 and 1/2
    assert isotropic_wheel_torque(np.linalg.pinv(nasa_standard_axes().T), np.full(4, 0.2)) == pytest.approx(
        0.2 / (np.sqrt(27.0) / 6.0), rel=1e-14)
    torque = np.array([0.3, -0.4, 1.2])  # |M| = 1.3
    fine = fine_part(torque, 0.26)
    assert np.allclose(fine, torque * 0.2, rtol=1e-15) and np.allclose(fine_part(torque, 2.0), torque, rtol=0)


@pytest.mark.parametrize("override, field, words", [
    ("pipeline.allocator.wheel_torque_nm=0", "pipeline.allocator.wheel_torque_nm", ""),
    ("pipeline.allocator.steering=magic", "pipeline.allocator.steering", "unknown steering law"),
    ("pipeline.allocator={type: hybrid_split, beta_rate_max_deg_s: 10, wheel_allocator: wheel_minimax, "
     "null_space_gain_per_s: 0.1}", "pipeline.allocator.wheel_allocator", "null-space"),
    ("pipeline.allocator={type: wheel_pinv}", "pipeline.allocator.type", "hybrid_split"),
    ("pipeline.allocator={type: minimax, beta_rate_max_deg_s: 10}", "pipeline.allocator.type", "hybrid_split"),
    ("model.wheels.wheel_speeds_rpm=[1, 2]", "model.wheels.wheel_speeds_rpm", "4 wheels"),
    ("model.wheels.array=custom", "model.wheels.wheels", "1 to 8"),
])
def test_bad_hybrid_buses_are_refused_before_the_run(override, field, words, tmp_path, capsys):
    """One line naming the field, exit 2, no trace (the checks dropped: an allocator of one kind
    leaves the other kind's metrics out, which is refused first)."""
    out = tmp_path / "x.rrd"
    code = main(["run", "hybrid_slew", "--set", override, "--set", "checks={}", "--out", str(out)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and err.startswith(f"error: {field}:") and words in err, err
    assert not out.exists()


def test_the_envelope_of_a_hybrid_bus_is_its_clusters(capsys, tmp_path):
    """`testbed envelope` of hybrid_slew: its CMG pyramid's (h = 25 N m s, b = 54.74 deg), the wheels apart:
    S(z) = 4 h sin b and S(x) = 2 h (1 + cos b), the support sum over the four gimbal axes (exact: 1e-12)."""
    out = tmp_path / "e.rrd"
    assert main(["envelope", "hybrid_slew", "--points", "300", "--json", "--out", str(out)]) == 0
    found = json.loads(capsys.readouterr().out)
    b, h = np.arccos(1.0 / np.sqrt(3.0)), 25.0
    assert found["units"] == 4
    assert found["extent_nms"]["z"] == pytest.approx(4 * h * np.sin(b), rel=1e-12)
    assert found["extent_nms"]["x"] == pytest.approx(2 * h * (1 + np.cos(b)), rel=1e-12)


def test_hybrid_split_needs_wheels_on_the_bus(tmp_path, capsys):
    out = tmp_path / "x.rrd"
    assert main(["run", "pyramid_slew", "--set", "pipeline.allocator.type=hybrid_split", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: pipeline.allocator.type:") and "model.wheels" in err and len(err.splitlines()) == 1


@pytest.mark.slow
def test_the_shipped_hybrid_slew_splits_as_its_rule_says():
    """hybrid_slew passes its checks; the wheels took |M_w| = min(|M|, tau_f) at every tick (the share's
    least value is tau_f / max |M|, tau_f = (4/3) u_max = 0.2667 N m for its wheel pyramid), so no wheel
    motor passed its limit; the law's torque was delivered in full (torque_error_rel at round-off)."""
    data, _ = load_mapping("hybrid_slew")
    result = run_scenario(parse(copy.deepcopy(data)), None, keep_data=True)
    assert result.passed, result.checks
    _, share = result.trace["allocator/wheel_share"]
    _, torque = result.trace["law/torque"]
    size = np.linalg.norm(torque, axis=1)
    limit = 4.0 / 3.0 * data["model"]["wheels"]["wheel"]["max_torque_nm"]
    expected = np.where(size > limit, limit / np.where(size > 0, size, 1.0), np.where(size > 0, 1.0, 0.0))
    assert np.max(np.abs(share[:, 0] - expected)) < 1e-12
    assert result.metrics["peak_wheel_torque_fraction"] <= 1.0 and result.metrics["torque_error_rel"] < 1e-12


def test_the_shipped_hybrid_slew_loads():
    scenario = load_scenario("hybrid_slew")
    assert scenario.model.wheels is not None and scenario.stages["allocator"][0] == "hybrid_split"


@pytest.mark.slow
def test_the_wheels_take_what_the_rate_limited_cmgs_cannot_deliver():
    """(HY-3) on hybrid_slew with the gimbal rate limited to 2.5 deg/s (the slew asks 3.7), wheels of 1 N m
    and tau_f 0.1 N m: the CMGs' steering scales its part (min_scale < 1) and the wheels take the rest, so the
    law's torque is delivered in full (the sum is the demand: round-off) and the slew ends on target; without
    the rule the same run loses most of its torque and misses the target by most of a degree."""
    data, _ = load_mapping("hybrid_slew")
    data["checks"] = {}
    data["model"]["wheels"]["wheel"]["max_torque_nm"] = 1.0
    data["pipeline"]["allocator"] |= {"beta_rate_max_deg_s": 2.5, "wheel_torque_nm": 0.1}
    taken = run_scenario(parse(copy.deepcopy(data)), None).metrics
    data["pipeline"]["allocator"]["wheels_take_shortfall"] = False
    left = run_scenario(parse(copy.deepcopy(data)), None).metrics
    assert taken["min_scale"] < 0.9 and taken["min_wheel_scale"] == 1.0
    assert taken["torque_error_rel"] < 1e-12 and taken["final_attitude_error_deg"] < 1e-4
    assert left["torque_error_rel"] > 0.5 and left["final_attitude_error_deg"] > 0.1
