"""The validation scenarios: MuJoCo truth against analytic models, each with its own checks.

Each scenario's checks bound the largest difference from an independent solution (closed
form, ODE, reduced model) or a conservation law; here every check must exist and pass.
"""

import pytest

from testbed.runner import run_scenario
from testbed.scenario.loading import load_scenario

# scenario -> the checks it must carry (with the bounds at least this tight)
REQUIRED = {
    "torque_free_skylab": {"max_omega_error_rad_s": 1e-9},
    "torque_free_tumble": {"max_omega_error_rad_s": 1e-9},
    "gyrostat_free": {"max_omega_error_rad_s": 1e-8},
    "cmg_open_loop": {"momentum_drift_rel": 1e-9, "gimbal_rate_error_rel": 0.01, "max_omega_error_rad_s": 1e-6},
    "reaction_wheel_slew": {"momentum_drift_rel": 1e-10, "final_pointing_error_deg": 3.4e-4},
    "hybrid_slew": {"momentum_drift_rel": 1e-9, "max_omega_error_rad_s": 1e-8},
}


@pytest.mark.slow  # whole-scenario runs (cmg_open_loop alone takes ~7 s)
@pytest.mark.parametrize("name", sorted(REQUIRED))
def test_validation_scenario_passes_its_checks(name, tmp_path):
    scenario = load_scenario(name)
    for check, bound in REQUIRED[name].items():
        assert scenario.checks[check].max <= bound, f"{name}: {check} bound looser than {bound}"
    result = run_scenario(scenario, tmp_path / f"{name}.rrd")
    assert result.status == "ok", result.error
    failed = [c for c in result.checks if not c["passed"]]
    assert not failed, failed
    assert (tmp_path / f"{name}.rrd").stat().st_size > 0
