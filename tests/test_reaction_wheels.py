"""The reaction-wheel system and the allocator wheel_pinv against independent numbers: the
compiled inertia against a hand sum, momentum conservation, a constant wheel torque against the
gyrostat equations (solve_ivp) and, at zero momentum, against their closed form, the bearing
friction against its closed form, the allocator against least squares and its own limits, and a
slew against the bound of the law's closed-loop response (docs/theory/reaction-wheels.md)."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from scipy.optimize import brentq

from coast_cases import Initial, coast_drift
from testbed.cli import main
from testbed.errors import InputError
from testbed.guidance.slew import SlewParams, build_program
from testbed.math.quaternion import quat_angle, quat_conj, quat_from_axis_angle, quat_mul
from testbed.references.gyrostat_ode import gyrostat_omega
from testbed.runner import run_scenario
from testbed.scenario.loading import load_mapping, parse
from testbed.scenario.schema import load
from testbed.systems.reaction_wheels.allocator import WheelAllocationParams, WheelPseudoInverse
from testbed.systems.reaction_wheels.model import RPM, ReactionWheelsParams, build
from testbed.systems.reaction_wheels.plant import ReactionWheelPlant
from testbed.systems.reaction_wheels.wheel_array import (
    ISOTROPIC_SKEW_DEG, nasa_standard_axes, pyramid_axes, three_orthogonal_axes)

# A bus with products of inertia that is none of the shipped ones (principal axes far from the bus axes).
TENSOR = [[260.0, -31.0, 17.0], [-31.0, 310.0, -24.0], [17.0, -24.0, 205.0]]


def plant_of(model: dict, dt: float = 0.01, omega=(0.0, 0.0, 0.0)) -> ReactionWheelPlant:
    params = load(ReactionWheelsParams, {"inertia_tensor_kg_m2": TENSOR} | model, "model")
    plant = ReactionWheelPlant(build(params, dt, "RK4"), params)
    plant.initialise(Initial(omega))
    return plant


def locked_inertia_by_hand(params: ReactionWheelsParams) -> np.ndarray:
    """Bus tensor + each wheel's Jt 1 + (Js - Jt) a a^T + parallel-axis terms, moved to the system CoM."""
    inertia = np.array(params.inertia_tensor_kg_m2, float)
    masses, positions = [], params.positions()
    for axis, unit, r in zip(params.axes(), params.units(), positions):
        js, jt, m = unit.spin_inertia_kg_m2, unit.transverse_inertia_kg_m2, unit.mass_kg
        inertia += jt * np.eye(3) + (js - jt) * np.outer(axis, axis) + m * (r @ r * np.eye(3) - np.outer(r, r))
        masses.append(m)
    total = params.mass_kg + sum(masses)
    com = np.asarray(masses) @ positions / total
    return inertia - total * (com @ com * np.eye(3) - np.outer(com, com))


# --- the arrays -----------------------------------------------------------------------------------

def test_preset_axes_are_the_textbook_arrays():
    assert np.array_equal(three_orthogonal_axes(), np.eye(3))
    pyramid = pyramid_axes(ISOTROPIC_SKEW_DEG)
    # at the isotropic skew each body axis sees the same capacity: A A^T = 4/3 1
    assert np.allclose(pyramid.T @ pyramid, 4.0 / 3.0 * np.eye(3), atol=1e-15)
    # at 60 deg the z capacity is 4 cos^2 = 1, x and y 2 sin^2 = 1.5
    assert np.allclose(np.diag(pyramid_axes(60.0).T @ pyramid_axes(60.0)), [1.5, 1.5, 1.0], atol=1e-15)
    nasa = nasa_standard_axes()
    assert np.allclose(nasa[3], np.ones(3) / np.sqrt(3.0)) and np.allclose(nasa[:3], np.eye(3))
    assert np.allclose(np.linalg.norm(pyramid, axis=1), 1.0, atol=1e-15)


def test_a_custom_array_takes_its_wheels_own_properties():
    params = load(ReactionWheelsParams, {"array": "custom", "wheel": {"max_torque_nm": 0.1}, "wheels": [
        {"axis": [1, 0, 0]}, {"axis": [0, 0.6, 0.8], "max_torque_nm": 0.3, "position_m": [0, 0, -0.5]}]}, "model")
    array = params.wheel_array()
    assert array.count == 2 and np.allclose(array.torque_max, [0.1, 0.3])
    assert np.allclose(params.positions(), [[0.3, 0, 0], [0, 0, -0.5]])


@pytest.mark.parametrize("model, field, words", [
    ({"inertia_tensor_kg_m2": [[300, 10, 0], [-10, 300, 0], [0, 0, 300]]}, "model.inertia_tensor_kg_m2", "symmetric"),
    ({"inertia_tensor_kg_m2": [[300, 400, 0], [400, 300, 0], [0, 0, 300]]}, "model.inertia_tensor_kg_m2",
     "positive definite"),
    ({"inertia_tensor_kg_m2": [[100, 0, 0], [0, 100, 0], [0, 0, 300]]}, "model.inertia_tensor_kg_m2", "triangle"),
    ({"inertia_tensor_kg_m2": [[300, 0], [0, 300]]}, "model.inertia_tensor_kg_m2", "3 elements"),
    ({"array": "custom"}, "model.wheels", "1 to 8"),
    ({"array": "custom", "wheels": [{"axis": [1, 0, 0]}] * 9}, "model.wheels", "1 to 8"),
    ({"wheels": [{"axis": [1, 0, 0]}]}, "model.wheels", "array: custom"),
    ({"array": "custom", "wheels": [{"axis": [1, 1, 0]}]}, "model.wheels[0].axis", "unit vector"),
    ({"wheel": {"spin_inertia_kg_m2": 0.05, "transverse_inertia_kg_m2": 0.02}}, "model.wheel.spin_inertia_kg_m2",
     "Js <= 2 Jt"),
    ({"wheel_speeds_rpm": [0, 0, 0]}, "model.wheel_speeds_rpm", "4 wheels"),
    ({"wheel_speeds_rpm": [0, 7000, 0, 0]}, "model.wheel_speeds_rpm[1]", "max_speed_rpm"),
])
def test_bad_models_are_refused_naming_the_field(model, field, words):
    with pytest.raises(InputError) as caught:
        load(ReactionWheelsParams, model, "model")
    assert caught.value.field == field and words in caught.value.reason, str(caught.value)


def test_a_bad_tensor_on_the_command_line_is_one_line_and_exit_2(tmp_path, capsys):
    out = tmp_path / "out.rrd"
    status = main(["run", "reaction_wheel_slew", "--set", "model.inertia_tensor_kg_m2=[[100,0,0],[0,100,0],[0,0,300]]",
                   "--out", str(out)])
    err = capsys.readouterr().err.strip()
    assert status == 2 and len(err.splitlines()) == 1 and "model.inertia_tensor_kg_m2" in err and "triangle" in err
    assert not out.exists() and "Traceback" not in err


def test_the_compiled_inertia_is_the_hand_sum_with_products_of_inertia():
    """MuJoCo's locked inertia (mass matrix, moved to the CoM) against the hand sum: the same sums in
    another order, tight (1e-12 of the largest moment)."""
    for model in ({"array": "pyramid", "skew_deg": 40.0}, {"array": "nasa_standard", "mount_radius_m": 0.7},
                  {"array": "custom", "wheels": [{"axis": [0, 0.8, -0.6], "position_m": [0.2, -0.4, 0.1]}]}):
        params = load(ReactionWheelsParams, {"inertia_tensor_kg_m2": TENSOR} | model, "model")
        plant = plant_of(model)
        assert np.allclose(plant.locked_inertia(), locked_inertia_by_hand(params), rtol=0, atol=1e-12 * 310)
        assert np.allclose(plant.applied()["model.inertia_tensor_kg_m2"], TENSOR, rtol=0, atol=1e-12 * 310)


# --- the dynamics ---------------------------------------------------------------------------------

SPINNING = {"array": "nasa_standard", "wheel_speeds_rpm": [3000, -2000, 1000, 4500]}
TUMBLE = (0.02, -0.035, 0.015)


def test_momentum_is_conserved_in_a_torque_free_coast_with_wheels_spinning():
    """Total momentum about the CoM, world frame, over 2000 RK4 steps of a tumbling bus with the wheels
    at 1000-4500 rpm: round-off only (the step's truncation error does not change L, which the
    integrator carries implicitly, but each step's sum of ~1e-16-relative terms does). Measured
    2e-13 of |L|; the band 1e-12 is 2000 steps of a few ulps, and a lost term (a wheel's inertia
    frame misplaced, measured 8e-3 before it was fixed) is far above it."""
    plant = plant_of(SPINNING, omega=TUMBLE)
    start = plant.angular_momentum_world()
    assert coast_drift(plant, 200, 10) <= 1e-12 * np.linalg.norm(start)


def test_a_constant_wheel_torque_follows_the_gyrostat_equations():
    """Motor torques u held constant on a tumbling bus with products of inertia: each wheel's absolute
    axial momentum Js (Omega_i + a_i . w) grows as u_i t exactly (the motor is the only torque about
    the wheel's axis), and the body rate follows I' w' + w x (I' w + A h(t)) = -A u, I' = I - sum Js a a^T
    (docs/theory/reaction-wheels.md, eq. RW-2), integrated by DOP853 at rtol 1e-12. RK4 at dt 0.01 s
    against rates of 0.04 rad/s: local error ~(w dt)^5; measured 5e-14 rad/s, the band 1e-12 rad/s
    is 2.5e-11 of the rates (the reference's own tolerance is 1e-12 relative)."""
    plant = plant_of(SPINNING, omega=TUMBLE)
    array = plant.description()
    torques = np.array([0.08, -0.05, 0.12, -0.1])
    inertia = plant.locked_inertia()
    reduced = inertia - np.einsum("i,ij,ik->jk", array.spin_inertia, array.axes, array.axes)
    absolute0 = array.spin_inertia * (plant.wheel_rates() + array.axes @ plant.omega())
    times = np.arange(0.0, 20.0 + 1e-9, 0.5)
    reference = gyrostat_omega(reduced, lambda t: (absolute0 + torques * t) @ array.axes, TUMBLE, times,
                               h_dot=lambda t: torques @ array.axes)
    plant.apply({"wheel_torques": torques})
    worst_rate, worst_axial = 0.0, 0.0
    for k, t in enumerate(times):
        if k:
            plant.step(50)
        omega = plant.omega()
        worst_rate = max(worst_rate, float(np.linalg.norm(omega - reference[k])))
        absolute = array.spin_inertia * (plant.wheel_rates() + array.axes @ omega)
        worst_axial = max(worst_axial, float(np.max(np.abs(absolute - (absolute0 + torques * t)))))
    assert worst_rate < 1e-12
    assert worst_axial < 1e-12 * np.max(np.abs(absolute0 + torques * times[-1]))
    assert np.linalg.norm(reference[-1] - reference[0]) > 1e-3  # the torques did turn the bus


def test_at_zero_momentum_a_wheel_torque_turns_the_bus_about_a_fixed_axis_in_closed_form():
    """From rest, L = I' w + A h = 0 for all time, so w = -I'^-1 A u t (exact): the bus turns about
    the fixed axis -I'^-1 A u, by |I'^-1 A u| t^2 / 2. With products of inertia that axis is not A u."""
    plant = plant_of({"array": "pyramid", "skew_deg": 35.0})
    array = plant.description()
    torques = np.array([0.15, 0.02, -0.07, 0.1])
    reduced = plant.locked_inertia() - np.einsum("i,ij,ik->jk", array.spin_inertia, array.axes, array.axes)
    spin = -np.linalg.solve(reduced, torques @ array.axes)  # w = spin t
    axis = spin / np.linalg.norm(spin)
    assert np.degrees(np.arccos(abs(axis @ (torques @ array.axes)) / np.linalg.norm(torques @ array.axes))) > 5
    plant.apply({"wheel_torques": torques})
    for t in (10.0, 20.0, 30.0):
        plant.step(1000)
        expected = quat_from_axis_angle(axis, np.linalg.norm(spin) * t**2 / 2)
        assert np.linalg.norm(plant.omega() - spin * t) < 1e-12 * np.linalg.norm(spin * t)
        assert quat_angle(quat_mul(quat_conj(expected), plant.quat())) < 1e-11


@pytest.mark.parametrize("kind", ["viscous", "coulomb"])
def test_bearing_friction_spins_a_wheel_down_as_its_closed_form(kind):
    """One wheel along a principal axis of the locked inertia, mounted on that axis: the motion stays
    about it, and the friction between wheel and bus takes the relative speed Omega down with
    1/J = 1/Js + 1/I'_a. Viscous c: Omega(t) = Omega0 exp(-c t / J) (MuJoCo's joint damping); RK4 at
    dt 1 ms against a 10 s decay: measured 4e-15 of Omega0, band 1e-12. Coulomb f: Omega(t) =
    Omega0 - f t / J until it stops (MuJoCo's frictionloss, a soft constraint whose force sits at its
    bound f while the wheel slides): measured 3e-11 of the speed lost, band 1e-9. Both conserve the
    total momentum (internal torques)."""
    params = load(ReactionWheelsParams, {"inertia_tensor_kg_m2": TENSOR}, "model")
    axis = np.linalg.eigh(np.array(TENSOR))[1][:, 1]
    wheel = {"array": "custom", "wheels": [{"axis": axis.tolist()}], "wheel_speeds_rpm": [3000.0],
             "wheel": ({"viscous_friction_nms_rad": 0.002} if kind == "viscous" else {"coulomb_friction_nm": 0.004})}
    plant = plant_of(wheel, dt=0.001)
    reduced = plant.locked_inertia() - params.wheel.spin_inertia_kg_m2 * np.outer(axis, axis)
    assert np.allclose(reduced @ axis, (axis @ reduced @ axis) * axis, atol=1e-9)  # a principal axis
    inverse = 1.0 / params.wheel.spin_inertia_kg_m2 + 1.0 / (axis @ reduced @ axis)
    start, momentum = 3000.0 * RPM, plant.angular_momentum_world()
    for t in (2.0, 4.0, 6.0):
        plant.step(2000)
        speed = plant.wheel_rates()[0]
        if kind == "viscous":
            assert abs(speed - start * np.exp(-0.002 * inverse * t)) < 1e-12 * start
        else:
            expected = start - 0.004 * inverse * t
            assert abs(speed - expected) < 1e-9 * (start - expected)
    assert np.linalg.norm(plant.angular_momentum_world() - momentum) < 1e-11 * np.linalg.norm(momentum)


# --- the allocator ---------------------------------------------------------------------------------

class Context:
    """What wheel_pinv reads of a StageContext."""

    def __init__(self, array, period=0.1, law_compensates=True, system="reaction_wheels"):
        from testbed.pipeline import StageInfo
        self.description, self.control_period, self.system = array, period, system
        self.stages = {"law": StageInfo("quaternion_feedback", {"compensates_internal_momentum": law_compensates})}


def allocator(model: dict, law_compensates=True, **params):
    array = load(ReactionWheelsParams, model, "model").wheel_array()
    return WheelPseudoInverse(load(WheelAllocationParams, params, "pipeline.allocator"),
                              Context(array, law_compensates=law_compensates)), array


def test_the_allocation_is_the_least_squares_minimum_norm_one():
    """Unsaturated, A u = -M exactly and u is the minimum-norm solution (numpy's lstsq, an SVD, as
    the second method); with w x H left to the allocator, A u = -(M + w x H)."""
    stage, array = allocator({"array": "pyramid", "skew_deg": 48.0})
    torque, rates = np.array([0.05, -0.08, 0.03]), np.array([200.0, -100.0, 50.0, 30.0])
    out = stage.allocate(0.0, {"torque": torque}, {"omega": np.zeros(3)}, {"wheel_rate": rates})
    expected = np.linalg.lstsq(array.distribution, -torque, rcond=None)[0]
    assert np.allclose(out["wheel_torques"], expected, rtol=0, atol=1e-15)
    assert np.allclose(out["torque_delivered"], torque, rtol=0, atol=1e-15) and out["scale"][0] == 1.0
    stage, _ = allocator({"array": "pyramid", "skew_deg": 48.0}, law_compensates=False)
    omega = np.array([0.01, 0.02, -0.03])
    out = stage.allocate(0.0, {"torque": torque}, {"omega": omega}, {"wheel_rate": rates})
    wanted = -(torque + np.cross(omega, array.momentum(rates)))
    assert np.allclose(array.distribution @ out["wheel_torques"], wanted, rtol=0, atol=1e-15)


def test_saturation_scales_the_whole_command_keeping_its_direction():
    """A demand 5x the torque limit: every wheel's torque is scaled by one factor, the largest at the
    limit, the body torque along the demand; a wheel near its speed limit bounds the factor by the
    torque that reaches the limit in one period."""
    stage, array = allocator({"array": "nasa_standard"})
    torque = np.array([0.6, -0.4, 0.5])
    free = np.linalg.pinv(array.distribution) @ -torque
    out = stage.allocate(0.0, {"torque": torque}, {}, {"wheel_rate": np.zeros(4)})
    scale = out["scale"][0]
    assert np.isclose(scale, 0.2 / np.max(np.abs(free)), rtol=1e-14)
    assert np.allclose(out["wheel_torques"], scale * free, rtol=1e-14)
    assert np.isclose(np.max(np.abs(out["wheel_torques"])), 0.2, rtol=1e-14)
    assert np.allclose(out["torque_delivered"], scale * torque, rtol=1e-14)
    # wheel 1 (x) 0.5 rad/s below its limit: Js 0.02 x 0.5 / 0.1 s = 0.1 N m more at most
    limit = 6000 * RPM
    rates = np.array([limit - 0.5, 0.0, 0.0, 0.0]) * np.sign(free[0])
    out = stage.allocate(0.0, {"torque": torque}, {}, {"wheel_rate": rates})
    assert np.isclose(abs(out["wheel_torques"][0]), 0.02 * 0.5 / 0.1, rtol=1e-9)
    assert np.allclose(out["wheel_torques"], out["scale"][0] * free, rtol=1e-12)


def test_friction_is_compensated_on_top_of_the_allocation():
    stage, array = allocator({"array": "three_orthogonal", "wheel": {"viscous_friction_nms_rad": 1e-4,
                                                                    "coulomb_friction_nm": 0.003}})
    rates = np.array([100.0, -50.0, 0.0])
    out = stage.allocate(0.0, {"torque": np.array([0.01, 0.02, 0.03])}, {}, {"wheel_rate": rates})
    assert np.allclose(out["wheel_torques"], -np.array([0.01, 0.02, 0.03]) + [0.013, -0.008, 0.0], atol=1e-15)


def test_null_space_management_decays_the_null_momentum_without_a_body_torque():
    """A pyramid whose wheels hold momentum in the null space of A (H = 0): with no torque wanted the
    management term alone acts, turns no body axis (A u = 0) and, held over each period T, takes that
    momentum down by (1 - k T) per period: after m periods h = h0 (1 - k T)^m. The bus stays at rest."""
    model = {"system": "reaction_wheels", "inertia_tensor_kg_m2": TENSOR, "array": "pyramid", "wheel_speeds_rpm": [2000, -2000, 2000, -2000]}
    data = {"name": "null_space", "model": model, "initial": {"quat": [1, 0, 0, 0]},
            "sim": {"duration_s": 20.0, "dt_s": 0.01, "control_period_s": 0.1, "trace_period_s": 0.1},
            "pipeline": {"sensor": {"type": "ideal_attitude"}, "estimator": {"type": "attitude"},
                         "allocator": {"type": "wheel_pinv", "null_space_gain_per_s": 0.04}}}
    result = run_scenario(parse(data), None, keep_data=True)
    assert result.status == "ok", result.error
    _, rates = result.trace["truth/wheel_rate"]
    expected = 2000 * RPM * (1 - 0.04 * 0.1) ** 200  # k h0 = 0.17 N m: below the 0.2 N m limit
    # the wheel torque changes the wheel's absolute momentum; the bus, at rest, adds nothing: tight
    assert np.allclose(np.abs(rates[-1]), expected, rtol=1e-9)
    _, omega = result.trace["truth/omega"]
    assert np.max(np.abs(omega)) < 1e-12
    assert result.metrics["momentum_drift_rel"] < 1e-12


def test_the_allocator_refuses_what_it_cannot_serve():
    with pytest.raises(InputError, match="span three axes; model's 2 wheel"):
        allocator({"array": "custom", "wheels": [{"axis": [1, 0, 0]}, {"axis": [0, 1, 0]}]})
    with pytest.raises(InputError, match="span three axes; model's 4 wheel.* span 2"):
        allocator({"array": "custom", "wheels": [{"axis": [1, 0, 0]}, {"axis": [0, 1, 0]},
                                                 {"axis": [0.6, 0.8, 0]}, {"axis": [-1, 0, 0]}]})
    with pytest.raises(InputError, match="preferred_momentum_nms: gives 3 momenta; the array has 4"):
        allocator({"array": "pyramid"}, preferred_momentum_nms=[0, 0, 0])
    with pytest.raises(InputError, match="needs a system with reaction wheels"):
        WheelPseudoInverse(WheelAllocationParams(), Context(None, system="satellite"))


def minimax_stage(model: dict):
    from testbed.systems.reaction_wheels.minimax_allocation import WheelMinimax, WheelMinimaxParams
    array = load(ReactionWheelsParams, model, "model").wheel_array()
    stage = WheelMinimax(WheelMinimaxParams(), Context(array))
    stage.type_name = "wheel_minimax"
    return stage, array


def test_minimax_allocation_closed_form_is_the_linear_program():
    """wheel_minimax's closed form for four wheels (a one-dimensional null space: the least of a convex
    piecewise-linear function of t, at a crossing of two lines or an end of t's interval) against
    HiGHS's linear program, 200 demands on a 50 deg pyramid with unequal motor limits, friction fed
    forward and speed bounds that bind on some: the same least largest share to 1e-9 (HiGHS's
    tolerances), A u = H' to 1e-12. Along a wheel's own axis of the isotropic pyramid the min-max
    is 1/2 per unit torque against the pseudo-inverse's 3/4 (u = (1, 1, 1, -1)/2 against
    (1, 3, 1, -1)/4): a third less torque, 1.5 times the capacity."""
    from testbed.systems.reaction_wheels.minimax_allocation import least_largest_on_a_line, least_largest_torque
    model = {"array": "custom", "wheels": [{"axis": a.tolist(), "max_torque_nm": m} for a, m in
                                           zip(pyramid_axes(50.0), (0.2, 0.25, 0.15, 0.3))]}
    array = load(ReactionWheelsParams, model, "model").wheel_array()
    inverse, null = np.linalg.pinv(array.distribution), np.linalg.svd(array.distribution)[2][-1]
    rng = np.random.default_rng(38)
    bound_some = 0
    for wanted in rng.normal(scale=0.1, size=(200, 3)):
        friction = rng.uniform(-0.01, 0.01, 4)
        speed_bounds = (rng.uniform(-0.3, -0.02, 4), rng.uniform(0.02, 0.3, 4))
        program = least_largest_torque(array.distribution, wanted, array.torque_max, friction, speed_bounds)
        closed = least_largest_on_a_line(inverse @ wanted, null, array.torque_max, friction, speed_bounds)
        assert (program is None) == (closed is None)
        if closed is None:
            continue
        assert closed[1] == pytest.approx(program[1], rel=1e-9, abs=1e-12)
        assert np.allclose(array.distribution @ closed[0], wanted, rtol=0, atol=1e-12)
        assert np.all(closed[0] >= speed_bounds[0] - 1e-15) and np.all(closed[0] <= speed_bounds[1] + 1e-15)
        bound_some += bool(np.any(np.isclose(closed[0], speed_bounds[0]) | np.isclose(closed[0], speed_bounds[1])))
    assert bound_some > 20  # the speed bounds did bind
    axes = pyramid_axes(ISOTROPIC_SKEW_DEG)
    free = (np.full(4, -1e9), np.full(4, 1e9))
    u, share = least_largest_on_a_line(np.linalg.pinv(axes.T) @ axes[1], np.linalg.svd(axes.T)[2][-1], np.ones(4),
                                       np.zeros(4), free)
    assert share == pytest.approx(0.5, rel=1e-12) and np.allclose(u, [0.5, 0.5, 0.5, -0.5], atol=1e-12)
    assert np.max(np.abs(np.linalg.pinv(axes.T) @ axes[1])) == pytest.approx(0.75, rel=1e-12)


def test_minimax_delivers_what_the_pseudo_inverse_must_scale_and_works_round_a_saturated_wheel():
    """On the isotropic pyramid (0.2 N m motors) a 0.35 N m demand along wheel 2's axis: the pseudo-
    inverse needs 0.2625 N m of wheel 2 and scales the whole command to 0.2/0.2625; min-max delivers it
    whole at 0.175 N m a wheel. With wheel 1 at its speed limit (no more torque its way) the
    pseudo-inverse delivers nothing of a demand that asks wheel 1 for more; min-max delivers it
    whole with the other three (any three axes of the pyramid span the body), wheel 1 at 0."""
    model = {"array": "pyramid"}
    pinv, array = allocator(model)
    minimax, _ = minimax_stage(model)
    torque = -0.35 * array.axes[1]  # the demand on the bus; the wheels take +0.35 a_2
    rest = {"wheel_rate": np.zeros(4)}
    scaled = pinv.allocate(0.0, {"torque": torque}, {}, rest)
    assert scaled["scale"][0] == pytest.approx(0.2 / 0.2625, rel=1e-12)
    whole = minimax.allocate(0.0, {"torque": torque}, {}, rest)
    assert whole["scale"][0] == 1.0 and np.allclose(whole["torque_delivered"], torque, rtol=0, atol=1e-12)
    assert np.allclose(np.abs(whole["wheel_torques"]), 0.175, rtol=1e-9)
    limit = 6000 * RPM
    demand = np.array([-0.05, -0.02, -0.04])  # asks wheel 1 (x-leaning) to speed up
    assert (np.linalg.pinv(array.distribution) @ -demand)[0] > 0
    at_limit = {"wheel_rate": np.array([limit, 0.0, 0.0, 0.0])}
    assert pinv.allocate(0.0, {"torque": demand}, {}, at_limit)["scale"][0] == 0.0
    shared = minimax.allocate(0.0, {"torque": demand}, {}, at_limit)
    assert shared["scale"][0] == 1.0 and abs(shared["wheel_torques"][0]) <= 1e-12  # the other three, whole
    assert np.allclose(shared["torque_delivered"], demand, rtol=0, atol=1e-12)


# --- a slew ----------------------------------------------------------------------------------------

def switch_angle(limit, wn, zeta) -> float:
    """theta_s [rad] where Wie's rate limit lets go: (2 k / c) sin(theta_s / 2) = L, k = wn^2, c = 2 zeta wn."""
    return 2.0 * np.arcsin(limit * zeta / wn)


def cruise_time(angle, limit, wn, zeta) -> float:
    """Time [s] from the step of the target to the release of the rate limit: on the limit the rate
    obeys w' = -c (L + w) (the law with w x H compensated), w = L (1 - exp(-c t)), so the angle
    covered is L (t - (1 - exp(-c t)) / c); it must cover angle - theta_s."""
    c = 2 * zeta * wn
    left = angle - switch_angle(limit, wn, zeta)
    return brentq(lambda t: limit * (t - (1 - np.exp(-c * t)) / c) - left, 0.0, 10 * left / limit + 10 / c)


def error_bound(t, angle, limit, wn, zeta) -> float:
    """Bound [rad] on the error angle at time t [s] after the target's step: from the release on, the
    small-error loop theta'' + c theta' + k theta = 0 starts at theta_s = L c / k (to first order)
    with theta' = -L at most, whose solution stays inside L / (wn sqrt(1 - zeta^2)) exp(-zeta wn (t - t_s))
    (the envelope of the underdamped response to that state), t_s <= the cruise time."""
    release = cruise_time(angle, limit, wn, zeta)
    return limit / (wn * np.sqrt(1 - zeta**2)) * np.exp(-zeta * wn * (t - release))


def test_a_slew_with_wheels_stays_inside_the_closed_loop_bound():
    """A 65 deg slew of another bus (products of inertia) with the NASA-standard array and
    rate-limited quaternion feedback: after the rate limit lets go, the error at every sample stays
    inside the envelope of the law's second-order response (error_bound, times 1.05 for what it
    leaves out: the sine of the half angle, the wheels' axial inertia beside the locked one, 2e-4,
    and the 0.1 s hold of each command, wn T / 2 = 0.006 rad of phase). Measured: the error reaches
    0.95 of the envelope, so a loop 5 % slower than the law's fails."""
    angle, limit, wn, zeta, start = np.radians(65.0), np.radians(1.5), 0.12, 0.75, 2.0
    axis = np.array([-0.36, 0.48, 0.8])
    data = {"name": "wheel_slew_bound",
            "model": {"system": "reaction_wheels", "inertia_tensor_kg_m2": [[90, 6, -4], [6, 75, 8], [-4, 8, 60]], "mass_kg": 120,
                      "array": "nasa_standard", "wheel": {"spin_inertia_kg_m2": 0.01, "max_torque_nm": 0.3}},
            "initial": {"quat": [0.9, 0.3, -0.2, 0.2479919353]},
            "sim": {"duration_s": 160.0, "dt_s": 0.02, "control_period_s": 0.1, "trace_period_s": 0.5},
            "pipeline": {"sensor": {"type": "ideal_attitude"}, "estimator": {"type": "attitude"},
                         "law": {"type": "quaternion_feedback", "axis": axis.tolist(), "angle_deg": 65.0,
                                 "start_s": start, "natural_frequency_rad_s": wn, "damping_ratio": zeta,
                                 "rate_limit_deg_s": 1.5},
                         "allocator": {"type": "wheel_pinv"}}}
    result = run_scenario(parse(data), None, keep_data=True)
    assert result.status == "ok", result.error
    assert result.metrics["min_wheel_scale"] == 1.0  # unsaturated: the law's own loop
    times, quats = result.trace["truth/quat"]
    target = result.data.statistics["law"]["target_quat"]
    error = quat_angle(quat_mul(quat_conj(target), quats))
    after = times >= start + cruise_time(angle, limit, wn, zeta)
    bound = 1.05 * error_bound(times[after] - start, angle, limit, wn, zeta)
    assert np.all(error[after] <= bound), np.max(error[after] / bound)
    assert error[-1] < 1e-3 * np.radians(65.0)  # it did arrive
    assert result.metrics["momentum_drift_rel"] < 1e-10


def test_the_slew_law_flies_on_wheels_with_the_momentum_its_program_asks():
    """The `slew` law (the program of SEEDS §004 and the tracking law, which leaves w x H to the
    allocator) on the shipped bus, another slew: it ends at the target, and at zero momentum the
    wheels hold h = -A^+ I w*(t), so the peak wheel momentum is the program's peak rate through
    A^+ I (the program from testbed.guidance alone). At the peak the rate is stationary and the
    tracking law holds the rate error to ~1e-6 of it: measured 6e-7, band 1e-5."""
    data, _ = load_mapping("reaction_wheel_slew")
    law = {"axis": [0.48, 0.6, 0.64], "angle_deg": 50.0, "duration_s": 90.0, "start_s": 5.0,
           "natural_frequency_rad_s": 0.3, "damping_ratio": 0.9}
    data["pipeline"]["law"] = {"type": "slew"} | law
    data["checks"], data["sim"]["duration_s"] = {}, 110.0
    result = run_scenario(parse(copy.deepcopy(data)), None, keep_data=True)
    assert result.status == "ok", result.error
    _, quats = result.trace["truth/quat"]
    # 15 s after the program ends, the tracking error (peak 8e-5 rad) has decayed to 7.6e-6 rad
    assert quat_angle(quat_mul(quat_conj(result.data.statistics["law"]["target_quat"]), quats[-1])) < 2e-5
    params = load(ReactionWheelsParams, data["model"], "model")
    program = build_program(load(SlewParams, law, "pipeline.law"), [1.0, 0.0, 0.0, 0.0])
    rates = np.array([program.state(t)[1] for t in np.linspace(0.0, 90.0, 901)])  # the trace's 0.1 s
    per_rate = np.linalg.pinv(params.wheel_array().distribution) @ locked_inertia_by_hand(params)
    predicted = np.max(np.abs(rates @ per_rate.T)) / params.wheel_array().momentum_max[0]
    assert result.metrics["peak_wheel_momentum_fraction"] == pytest.approx(predicted, rel=1e-5)
    assert result.metrics["momentum_drift_rel"] < 1e-10


# --- the shipped scenario ---------------------------------------------------------------------------

def predicted_uses(data: dict) -> dict[str, float]:
    """The shipped slew's wheel use from its numbers alone: at zero total momentum A h = -I w (the
    allocation keeps h in the range of A^T, so h = -A^+ I w); the rate along the axis is
    L (1 - exp(-c t_s)) at the release and grows a little after it, never to L (the law's wanted
    rate is below L from then on): the peak momentum lies between the two (`momentum_low`,
    `momentum_high`). The first command is the whole -I c L e (w = 0), the largest torque."""
    params = load(ReactionWheelsParams, data["model"], "model")
    law = data["pipeline"]["law"]
    limit, wn, zeta = np.radians(law["rate_limit_deg_s"]), law["natural_frequency_rad_s"], law["damping_ratio"]
    c = 2 * zeta * wn
    array = params.wheel_array()
    per_rate = np.abs(np.linalg.pinv(array.distribution) @ locked_inertia_by_hand(params) @ np.asarray(law["axis"]))
    peak_rate = limit * (1 - np.exp(-c * cruise_time(np.radians(law["angle_deg"]), limit, wn, zeta)))
    return {"momentum_low": float(np.max(per_rate * peak_rate / array.momentum_max)),
            "momentum_high": float(np.max(per_rate * limit / array.momentum_max)),
            "torque": float(np.max(per_rate * c * limit / array.torque_max)),
            "final_bound_deg": float(np.degrees(error_bound(data["sim"]["duration_s"] - law["start_s"],
                                                            np.radians(law["angle_deg"]), limit, wn, zeta)))}


def test_the_shipped_slew_checks_bracket_the_predicted_numbers():
    """The check bounds of reaction_wheel_slew hold the numbers predicted here, not the run's."""
    data, _ = load_mapping("reaction_wheel_slew")
    checks, predicted = data["checks"], predicted_uses(data)
    momentum = checks["peak_wheel_momentum_fraction"]
    assert momentum["min"] <= predicted["momentum_low"] and predicted["momentum_high"] <= momentum["max"]
    assert momentum["max"] - momentum["min"] <= predicted["momentum_high"] - predicted["momentum_low"] + 2e-5
    torque = checks["peak_wheel_torque_fraction"]
    assert torque["min"] < predicted["torque"] < torque["max"] and torque["max"] - torque["min"] <= 1e-4
    assert checks["final_pointing_error_deg"]["max"] == pytest.approx(predicted["final_bound_deg"], rel=0.01)


@pytest.mark.slow  # a whole shipped scenario (about 1 s of simulation, 3 s with start-up)
def test_the_shipped_slew_passes_and_meets_the_predictions(tmp_path):
    data, _ = load_mapping("reaction_wheel_slew")
    result = run_scenario(parse(copy.deepcopy(data)), tmp_path / "slew.rrd")
    assert result.passed, [c for c in result.checks if not c["passed"]]
    predicted = predicted_uses(data)
    assert predicted["momentum_low"] <= result.metrics["peak_wheel_momentum_fraction"] <= predicted["momentum_high"]
    assert result.metrics["peak_wheel_torque_fraction"] == pytest.approx(predicted["torque"], rel=1e-9)


def test_coulomb_friction_keeps_the_momentum_of_a_tumbling_bus_and_its_energy_is_not_judged(tmp_path):
    """Three wheels sliding against Coulomb friction on a tumbling bus, then stopping against it
    (at 2.2, 4.3 and 6.4 s): the friction is internal. Sliding, measured 1e-15 of the momentum scale
    (band 1e-12; at MuJoCo's default solver tolerance it was 3e-5: model.py). The step in which a
    wheel stops holds the friction's switch inside one RK4 step: 9e-10 at dt 0.01 s (2e-15 at
    dt 0.002 s), band 1e-8. The energy falls (friction), and the accuracy guard does not count that
    as a drift."""
    model = {"system": "reaction_wheels", "inertia_tensor_kg_m2": TENSOR, "array": "three_orthogonal",
             "wheel": {"coulomb_friction_nm": 0.02}, "wheel_speeds_rpm": [60, -40, 20]}
    data = {"name": "coulomb_coast", "model": model, "initial": {"quat": [1, 0, 0, 0], "omega_deg_s": [0.5, -0.3, 0.2]},
            "sim": {"duration_s": 12.0, "dt_s": 0.01}}
    result = run_scenario(parse(copy.deepcopy(data)), None, keep_data=True)
    assert result.status == "ok" and result.passed, result.checks
    _, rates = result.trace["truth/wheel_rate"]
    assert np.max(np.abs(rates[-1])) < 1e-3 * 60 * RPM  # all three stopped against the bus
    assert result.metrics["momentum_drift_rel"] < 1e-8 and result.metrics["energy_drift_rel"] > 0.5
    data["sim"]["duration_s"] = 2.0  # still sliding
    assert run_scenario(parse(data), None).metrics["momentum_drift_rel"] < 1e-12
