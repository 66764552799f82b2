"""The reduced CMG model (testbed/systems/cmg_cluster/reduced_model.py) against the MuJoCo truth and
against MuJoCo's mass matrix and momentum bookkeeping."""

import mujoco
import numpy as np
import pytest

from testbed.systems import cmg_rhombus
from testbed.systems.cmg_cluster.cluster import ClusterGeometry
from testbed.systems.cmg_cluster.plant import CmgRhombus
from testbed.systems.cmg_rhombus import CmgRhombusParams
from testbed.systems.cmg_cluster.reduced_model import (
    CmgMassModel, reduced_cmg_omega, textbook_cmg_omega)

# different amplitude and frequency per gimbal, so beta(t) is not periodic as a whole
AMPLITUDE = np.array([0.10, 0.07, 0.12, 0.05])  # rad/s
FREQUENCY_HZ = np.array([0.05, 0.08, 0.11, 0.13])
OMEGA0 = np.array([0.01, -0.02, 0.015])  # rad/s


def simulate_truth(dt, duration):
    """MuJoCo run with sinusoidal gimbal-rate commands; histories sampled every step."""
    model = cmg_rhombus.build(CmgRhombusParams(), dt)
    data = mujoco.MjData(model)
    cmg = CmgRhombus(model)
    cmg.initialise(data, OMEGA0, [1.0, 0.0, 0.0, 0.0])
    steps = int(round(duration / dt))
    times = np.empty(steps + 1)
    beta, beta_rate, rotor_rate = (np.empty((steps + 1, 4)) for _ in range(3))
    omega = np.empty((steps + 1, 3))
    for k in range(steps + 1):
        times[k], omega[k] = data.time, cmg.body_omega(data)
        beta[k], beta_rate[k] = cmg.gimbal_angles(data), cmg.gimbal_rates(data)
        rotor_rate[k] = cmg.rotor_rates(data)
        if k < steps:
            cmg.set_gimbal_rate_command(data, AMPLITUDE * np.sin(2 * np.pi * FREQUENCY_HZ
                                                                 * data.time))
            mujoco.mj_step(model, data)
    assert data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number == 0
    return model, times, beta, beta_rate, rotor_rate, omega


@pytest.mark.parametrize("dt", [1e-3, 2e-3])
def test_reduced_model_matches_mujoco(dt):
    model, times, beta, beta_rate, rotor_rate, omega = simulate_truth(dt, 30.0)
    every = int(round(0.1 / dt))  # compare every 0.1 s
    reduced = reduced_cmg_omega(model, times, beta, beta_rate, rotor_rate, omega[0],
                                times[::every])
    error = np.max(np.abs(reduced - omega[::every]))
    # measured 5e-13 (dt 1e-3) and 1.5e-11 (dt 2e-3) rad/s over 20-30 s, 7e-12 / 7e-11 over
    # 600 s; the body rate itself reaches 0.035 rad/s
    assert error < 1e-9
    assert np.max(np.abs(omega)) > 0.02  # the test is not trivially at rest

    # the textbook form (constant I, spin momentum only) misses by far more than 1e-6 rad/s:
    # the corrections in the exact form are needed for the bound
    mass_model = CmgMassModel.from_model(model)
    textbook = textbook_cmg_omega(mass_model.system_inertia(beta[0]),
                                  ClusterGeometry.from_model(model), times, beta,
                                  beta_rate, omega[0], times[::every])
    assert np.max(np.abs(textbook - omega[::every])) > 1e-6


def test_mass_model_matches_mujoco_mass_matrix_and_momentum():
    model = cmg_rhombus.build(CmgRhombusParams(alpha_deg=40.0, rotor_transverse_ratio=0.7,
                                               gimbal_inertia_kg_m2=[0.05, 0.03, 0.04]), 1e-3)
    data = mujoco.MjData(model)
    cmg = CmgRhombus(model)
    mass_model = CmgMassModel.from_model(model)
    rng = np.random.default_rng(4)
    for _ in range(3):
        beta = rng.uniform(-np.pi, np.pi, 4)
        quat = rng.normal(size=4)
        cmg.initialise(data, rng.normal(scale=0.05, size=3), quat / np.linalg.norm(quat),
                       beta0=beta)
        data.qvel[cmg.gimbal_qvel_adr] = rng.normal(scale=0.5, size=4)
        data.qvel[cmg.rotor_qvel_adr] = rng.uniform(600.0, 650.0, size=4)
        mujoco.mj_forward(model, data)
        inertia = mass_model.system_inertia(beta)
        np.testing.assert_allclose(inertia, cmg.system_inertia(data), rtol=1e-12, atol=1e-10)
        internal = mass_model.internal_momentum(beta, cmg.gimbal_rates(data),
                                                cmg.rotor_rates(data))
        np.testing.assert_allclose(internal, cmg.internal_momentum_body(data), atol=1e-10)
        # total momentum from MuJoCo's subtree bookkeeping = I_sys w + H_int
        bus_rot = data.xmat[cmg.bus_body_id].reshape(3, 3)
        total_body = bus_rot.T @ cmg.total_angular_momentum_world(data)
        np.testing.assert_allclose(total_body, inertia @ cmg.body_omega(data) + internal,
                                   atol=1e-10)


def test_reduced_model_with_frozen_gimbals_is_torque_free_rigid_body():
    """With beta, beta', Omega constant, L_b' = -w x L_b conserves |L_b| and the kinetic
    energy of the relative motion E = 1/2 (L_b - H)^T I^-1 (L_b - H) (gyrostat integrals)."""
    model = cmg_rhombus.build(CmgRhombusParams(), 1e-3)
    mass_model = CmgMassModel.from_model(model)
    times = np.linspace(0.0, 200.0, 11)
    beta = np.tile([0.3, -0.5, 0.9, 0.2], (times.size, 1))
    rotor = np.full((times.size, 4), 628.0)
    zero_rates = np.zeros((times.size, 4))
    omega = reduced_cmg_omega(mass_model, times, beta, zero_rates, rotor,
                              [0.05, -0.03, 0.04], times)
    inertia = mass_model.system_inertia(beta[0])
    internal = mass_model.internal_momentum(beta[0], np.zeros(4), rotor[0])
    momentum = omega @ inertia.T + internal
    energy = 0.5 * np.einsum("ni,ij,nj->n", omega, inertia, omega)
    np.testing.assert_allclose(np.linalg.norm(momentum, axis=1),
                               np.linalg.norm(momentum[0]), rtol=1e-11)
    np.testing.assert_allclose(energy, energy[0], rtol=1e-10)


def test_a_window_frees_its_splines_when_it_returns():
    """scipy's solver object refers to itself, so it lives until a full garbage collection with
    everything its right-hand side reaches: the window's input splines (3.5 MB for 8192
    samples) must not be among that, or a long run's memory grows between collections."""
    import gc

    from testbed.systems.cmg_cluster.reduced_model import GimbalHistory, reduced_cmg_segment
    model, times, beta, beta_rate, rotor_rate, omega = simulate_truth(2e-3, 1.0)
    gc.collect()
    gc.disable()
    try:
        reduced_cmg_segment(model, times, beta, beta_rate, rotor_rate, times[::50], omega0=omega[0])
        alive = [o for o in gc.get_objects() if isinstance(o, GimbalHistory)]
        solvers = [o for o in gc.get_objects() if type(o).__name__ == "DOP853"]
    finally:
        gc.enable()
    assert solvers, "the solver's cycle is not there: this test no longer sees what it guards"
    assert alive == []
