"""The spacecraft bench/bench_basilisk.py hands Basilisk is the testbed's: summed the way Basilisk
sums a hub and balanced VSCMGs, its numbers give MuJoCo's locked inertia and the rotor momenta
the scenario asks for. No Basilisk is needed (the script builds with it in its own venv only).
Checked on a spacecraft that is not the shipped one (other bus, rhombus angle, momentum and
angles). Well-conditioned sums of O(1e3) kg m^2: pinned at 1e-12 relative (round-off is 1e-16)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import testbed
from testbed.systems import registry as systems_registry

SCRIPT = Path(__file__).resolve().parents[1] / "bench" / "bench_basilisk.py"
OTHER = ["model.inertia_kg_m2=[650, 1400, 1100]", "model.alpha_deg=48", "model.rotor_momentum_nms=35",
         "model.gimbal_angles_deg=[12, -75, 33, 101]"]


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location("bench_basilisk", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def craft_and_plant(bench):
    scenario = testbed.load(bench.SCENARIO, OTHER)
    plant = systems_registry.make_plant(scenario)
    plant.initialise(scenario.initial)
    return bench.spacecraft(OTHER), plant


def test_locked_inertia_is_mujocos(bench, craft_and_plant):
    craft, plant = craft_and_plant
    angles = [u["gamma0"] for u in craft["units"]]
    np.testing.assert_allclose(np.radians([12, -75, 33, 101]), angles, rtol=0, atol=1e-15)
    expected = plant.locked_inertia()
    assert np.abs(np.array(bench.locked_inertia(craft, angles)) - expected).max() < 1e-12 * np.abs(expected).max()


def test_rotor_momenta_and_frames(craft_and_plant):
    craft, plant = craft_and_plant
    for u, spin in zip(craft["units"], plant.geometry.spin_axes([u["gamma0"] for u in craft["units"]])):
        assert u["rotor_inertia"][0][0] * u["omega0"] == pytest.approx(35.0, rel=1e-12)
        frame = np.column_stack([u["gs0"], u["gt0"], u["gg"]])
        np.testing.assert_allclose(frame.T @ frame, np.eye(3), atol=1e-15)  # orthonormal
        assert np.linalg.det(frame) == pytest.approx(1.0, abs=1e-15)  # right-handed: gs0 x gt0 = gg
        # Basilisk turns gs by +gamma about gg: cos g gs0 + sin g gt0 is the testbed's spin axis
        turned = np.cos(u["gamma0"]) * np.array(u["gs0"]) + np.sin(u["gamma0"]) * np.array(u["gt0"])
        np.testing.assert_allclose(turned, spin, atol=1e-15)
    assert np.linalg.norm(craft["omega0"]) > 0 and craft["control_period"] == 0.01
