"""The files shipped with the testbed: the MJCF models (one per system), opened as MjSpec with
the run's integrator and step, and the scenario files.

They live at the top of the repository (models/, scenarios/); testbed/models and
testbed/scenarios link to them, and a wheel carries them there as package data, so the same
path serves a checkout, an editable install and an installed wheel, from any working directory.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from testbed.errors import InputError

if TYPE_CHECKING:
    import mujoco

MODELS_DIR = Path(__file__).resolve().parents[1] / "models"
SCENARIO_DIR = Path(__file__).resolve().parents[1] / "scenarios"

# The scenario's integrator names and MuJoCo's enum members (MuJoCo is imported where a model is
# built: `testbed list` reads the scenario files without it).
INTEGRATORS = {"Euler": "mjINT_EULER", "RK4": "mjINT_RK4", "implicit": "mjINT_IMPLICIT",
               "implicitfast": "mjINT_IMPLICITFAST"}


def load_spec(file_name: str, timestep: float, integrator: str) -> mujoco.MjSpec:
    """models/<file_name> as an MjSpec, its timestep and integrator set (parameters are
    applied by the caller through the spec, never by editing the XML text)."""
    import mujoco

    spec = mujoco.MjSpec.from_file(str(MODELS_DIR / file_name))
    spec.option.timestep = timestep
    spec.option.integrator = getattr(mujoco.mjtIntegrator, INTEGRATORS[integrator])
    return spec


def compile_model(spec: mujoco.MjSpec) -> mujoco.MjModel:
    """spec.compile(); a model MuJoCo refuses (e.g. a mass or inertia below its 1e-15 floor) is
    bad input naming the element, not a traceback."""
    try:
        return spec.compile()
    except ValueError as exc:
        lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
        raise InputError("model", f"MuJoCo cannot build it: {'; '.join(lines[:2])}") from None
