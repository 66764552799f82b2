"""A bus whose own centre of mass is off its origin (`model.com_m`, on `cmg_cluster` and
`reaction_wheels`): the spacecraft turns about the system CoM, and every read-out, reference and
guidance inertia is taken about it (docs/your-spacecraft.md, "The bus's centre of mass").

Each test holds MuJoCo against a number computed here apart from the repository's read-outs: the
parallel-axis sum by hand, a rigid-body ODE (scipy's solve_ivp) with that inertia, the conservation
of momentum about the system CoM, and the same prediction with the offset ignored, which must miss.
"""

from __future__ import annotations

import copy

import numpy as np
from scipy.integrate import solve_ivp

from coast_cases import Initial, coast_drift
from testbed.cli import main
from testbed.scenario.schema import load
from testbed.systems.cmg_cluster.model import CmgClusterParams, build as build_cluster
from testbed.systems.cmg_cluster.plant import CmgPlant
from testbed.systems.cmg_cluster.reduced_model import CmgMassModel, reduced_cmg_segment
from testbed.systems.reaction_wheels.model import ReactionWheelsParams, build as build_wheels
from testbed.systems.reaction_wheels.plant import ReactionWheelPlant

# Neither shipped: a bus with products of inertia and its CoM 0.15-0.3 m off its origin, against a
# locked inertia of a few hundred kg m^2 (m |c|^2 = 60 kg m^2 for the 400 kg bus).
COM = [0.15, -0.22, 0.3]
TUMBLE = (0.03, -0.02, 0.025)
CLUSTER = {"array": {"preset": "pyramid", "skew_deg": 50.0, "mount_distance_m": 0.6}, "mass_kg": 400.0,
           "inertia_kg_m2": [300.0, 360.0, 280.0], "products_of_inertia_kg_m2": [12.0, -8.0, 5.0],
           "rotor_momentum_nms": 10.0, "rotor_mass_kg": 8.0, "gimbal_mass_kg": 3.0, "com_m": COM,
           "servo_model": "feedforward", "servo_natural_frequency_rad_s": 5.0}
WHEELS = {"array": "pyramid", "skew_deg": 40.0, "mount_radius_m": 0.4, "mass_kg": 350.0, "com_m": COM,
          "inertia_tensor_kg_m2": [[260.0, -31.0, 17.0], [-31.0, 310.0, -24.0], [17.0, -24.0, 205.0]],
          "wheel_speeds_rpm": [3000, -2000, 1000, 4500]}


def cluster_plant(model: dict = CLUSTER, dt: float = 0.01, omega=TUMBLE) -> CmgPlant:
    params = load(CmgClusterParams, copy.deepcopy(model), "model")
    plant = CmgPlant(build_cluster(params, dt), params, 0.05)
    plant.initialise(Initial(omega))
    return plant


def wheel_plant(model: dict = WHEELS, dt: float = 0.01, omega=TUMBLE) -> ReactionWheelPlant:
    params = load(ReactionWheelsParams, copy.deepcopy(model), "model")
    plant = ReactionWheelPlant(build_wheels(params, dt, "RK4"), params)
    plant.initialise(Initial(omega))
    return plant


def about_com(parts) -> np.ndarray:
    """sum over (mass [kg], CoM [m], own tensor about it [kg m^2]) of the tensor plus the parallel-axis
    term m (|r|^2 1 - r r^T), r from the parts' common CoM."""
    masses = np.array([m for m, _, _ in parts])
    com = masses @ np.array([c for _, c, _ in parts]) / masses.sum()
    total = np.zeros((3, 3))
    for m, c, tensor in parts:
        r = np.asarray(c) - com
        total += tensor + m * (r @ r * np.eye(3) - np.outer(r, r))
    return total


def cluster_by_hand(params: CmgClusterParams, com) -> np.ndarray:
    """The cluster spacecraft at its zero gimbal angles: the bus at `com`, each unit's gimbal frame and
    rotor (Jt = ratio Js about the transverse axes, Js = h / Omega about the spin axis e_i) at its mount."""
    units, js = params.units(), params.rotor_momentum_nms / params.rotor_speed
    parts = [(params.mass_kg, com, params.inertia_tensor())]
    for g, e, position in zip(units.gimbal_axes, units.spin_axes, units.positions):
        frame = np.column_stack([g, e, np.cross(g, e)])
        gimbal = frame @ np.diag(params.gimbal_inertia_kg_m2) @ frame.T
        rotor = js * (params.rotor_transverse_ratio * np.eye(3) + (1 - params.rotor_transverse_ratio) * np.outer(e, e))
        parts.append((params.gimbal_mass_kg + params.rotor_mass_kg, position, gimbal + rotor))
    return about_com(parts)


def wheels_by_hand(params: ReactionWheelsParams, com) -> np.ndarray:
    """The wheel spacecraft: the bus at `com`, each wheel Jt 1 + (Js - Jt) a a^T at its centre."""
    parts = [(params.mass_kg, com, np.array(params.inertia_tensor_kg_m2, float))]
    for axis, unit, position in zip(params.axes(), params.units(), params.positions()):
        tensor = unit.transverse_inertia_kg_m2 * np.eye(3) + (unit.spin_inertia_kg_m2 - unit.transverse_inertia_kg_m2) \
            * np.outer(axis, axis)
        parts.append((unit.mass_kg, position, tensor))
    return about_com(parts)


def test_the_locked_inertia_is_the_parallel_axis_sum_about_the_system_com():
    """MuJoCo's locked inertia (what guidance, gravity gradient and the references read) and the reduced
    model's, against the hand sum with the units' masses at their mounts: the same sums in another order,
    1e-12 of the largest moment. The sum with the bus's CoM at its origin (the offset ignored) is off by
    the two-body term m_bus m_units / (m_bus + m_units) (|c|^2 1 - c c^T): 5.5 kg m^2, 2 % of a moment."""
    params = load(CmgClusterParams, copy.deepcopy(CLUSTER), "model")
    plant = cluster_plant(omega=(0.0, 0.0, 0.0))
    by_hand, scale = cluster_by_hand(params, COM), 400.0
    assert np.allclose(plant.locked_inertia(), by_hand, rtol=0, atol=1e-12 * scale)
    assert np.allclose(CmgMassModel.from_model(plant.model).system_inertia(np.zeros(4)), by_hand, rtol=0,
                       atol=1e-12 * scale)
    assert np.abs(cluster_by_hand(params, np.zeros(3)) - by_hand).max() > 5.0
    assert np.allclose(plant.applied()["model.com_m"], COM, rtol=0, atol=1e-15)
    wheels = load(ReactionWheelsParams, copy.deepcopy(WHEELS), "model")
    assert np.allclose(wheel_plant(omega=(0.0, 0.0, 0.0)).locked_inertia(), wheels_by_hand(wheels, COM), rtol=0,
                       atol=1e-12 * scale)


def test_a_tumbling_wheel_bus_with_its_com_off_follows_the_rigid_body_ode():
    """Torque-free tumble of the wheel bus, wheels spinning with no motor torque: each wheel's absolute
    axial momentum Js (Omega_i + a_i . w) stays constant, so I' w' + w x (I' w + h_abs) = 0 with
    I' = I - sum Js a a^T, I the hand sum about the system CoM (solve_ivp, DOP853, rtol 1e-12). RK4 at
    0.01 s against rates of 0.04 rad/s: measured 4e-14 rad/s over 20 s; band 1e-11 rad/s (2.5e-10 of
    the rates). The same ODE with the bus's CoM at its origin misses by 2e-4 rad/s (band: more than 1e-4)."""
    params = load(ReactionWheelsParams, copy.deepcopy(WHEELS), "model")
    plant = wheel_plant()
    axes, js = params.axes(), np.array([u.spin_inertia_kg_m2 for u in params.units()])
    h_abs = (js * (params.initial_speeds() + axes @ np.asarray(TUMBLE))) @ axes
    times = np.arange(0.0, 20.0 + 1e-9, 0.5)

    def rates(inertia):
        reduced = inertia - np.einsum("i,ij,ik->jk", js, axes, axes)
        sol = solve_ivp(lambda t, w: np.linalg.solve(reduced, -np.cross(w, reduced @ w + h_abs)), (0.0, times[-1]),
                        np.asarray(TUMBLE, float), method="DOP853", t_eval=times, rtol=1e-12, atol=1e-15)
        return sol.y.T

    expected, ignored = rates(wheels_by_hand(params, COM)), rates(wheels_by_hand(params, np.zeros(3)))
    truth = [plant.omega()]
    for _ in times[1:]:
        plant.step(50)
        truth.append(plant.omega())
    truth = np.array(truth)
    assert np.abs(truth - expected).max() < 1e-11
    assert np.abs(truth - ignored).max() > 1e-4
    assert np.linalg.norm(truth[-1] - truth[0]) > 1e-3  # the bus does nutate


def test_momentum_about_the_system_com_is_conserved_and_the_com_stays_put_over_a_long_coast():
    """A tumbling cluster bus with its CoM off, rotors spinning, gimbals held, for 40 s at dt 0.002 s:
    the total momentum about the system CoM is conserved to RK4's truncation (measured 1.8e-11 of |L|,
    1.6e-11 without the offset; band 1e-10), and the system CoM starts and stays at rest (set by the
    free joint's initial velocity -w x c): it moves 7.7e-12 m (RK4's truncation on 0.3 m), band 1e-10 m,
    while the bus origin circles it by centimetres (with the origin at rest instead the CoM would drift
    at |w x c| = 6 mm/s)."""
    plant = cluster_plant(dt=0.002)
    start = plant.angular_momentum_world()
    origin0, com0 = plant.data.xpos[plant.bus.bus_body_id].copy(), plant.data.subtree_com[plant.bus.bus_body_id].copy()
    assert coast_drift(plant, 400, 50) <= 1e-10 * np.linalg.norm(start)
    plant.bus.refresh(plant.data, mass_matrix=False)
    bus = plant.bus.bus_body_id
    assert np.linalg.norm(plant.data.subtree_com[bus] - com0) < 1e-10
    assert np.linalg.norm(plant.data.xpos[bus] - origin0) > 1e-2


def test_the_reduced_model_with_gimbals_moving_takes_the_com_offset():
    """Constant gimbal rates on the tumbling cluster bus with its CoM off: MuJoCo's body rate against the
    reduced model L_b' = -w x L_b, w = I_sys(b)^-1 (L_b - H_int) from the recorded histories
    (`reduced_cmg`, its inertia read from the compiled model about the system CoM). Measured 1.1e-10
    rad/s over 4 s (RK4 at 0.01 s and the servo's start), band 1e-9 rad/s. The same model read from the bus with its
    CoM at its origin misses by more than 1e-5 rad/s (measured 6e-5: 60000 times the band)."""
    plant = cluster_plant()
    plant.apply({"gimbal_rates": np.radians([2.0, -1.5, 1.0, 3.0])})
    rows = {key: [] for key in ("t", "omega", "beta", "beta_rate", "rotor")}
    for k in range(81):
        if k:
            plant.step(5)
        truth = plant.truth()
        for key, value in (("t", plant.data.time), ("omega", plant.omega()), ("beta", truth["gimbal_angle"]),
                           ("beta_rate", truth["gimbal_rate"]), ("rotor", truth["rotor_rate"])):
            rows[key].append(value)
    h = {key: np.array(value) for key, value in rows.items()}

    def predicted(model):
        omega, _ = reduced_cmg_segment(CmgMassModel.from_model(model), h["t"], h["beta"], h["beta_rate"], h["rotor"],
                                       h["t"], omega0=h["omega"][0])
        return omega

    assert np.abs(predicted(plant.model) - h["omega"]).max() < 1e-9
    centred = cluster_plant(CLUSTER | {"com_m": [0.0, 0.0, 0.0]}).model
    assert np.abs(predicted(centred) - h["omega"]).max() > 1e-5


def test_a_bad_com_is_refused_naming_the_field(tmp_path, capsys):
    for scenario, setting, words in (("reaction_wheel_slew", "model.com_m=[0, 0, 500]", "model.com_m[2]: must be <= 100"),
                                     ("pyramid_slew", "model.com_m=[0.1, 0.2]", "model.com_m"),
                                     ("pyramid_slew", "model.com_m=[0, .nan, 0]", "model.com_m[1]")):
        out = tmp_path / "refused.rrd"
        assert main(["run", scenario, "--out", str(out), "--set", setting]) == 2
        err = capsys.readouterr().err.strip()
        assert words in err and len(err.splitlines()) == 1 and "Traceback" not in err and not out.exists()
