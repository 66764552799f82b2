"""Gymnasium environments of the testbed (docs/stepping.md "Gymnasium environments"), built on
`testbed.Simulation`; this package needs the optional extra `gym` (Gymnasium).

Importing it registers, under Gymnasium's namespace `testbed`:

- `testbed/CmgSlew-v0`: a rest-to-rest slew of the four-CMG bus, the action the body torque
  wanted (the scenario's own steering turns it into gimbal rates);
- `testbed/CmgSlewGimbalRates-v0`: the same slew, the action the gimbal rates themselves;
- `testbed/CmgSlewShort-v0`: CmgSlew-v0 cut down to be learnt in minutes (slews of 10-30 deg,
  a control period of 0.5 s, tolerances 1 deg and 0.1 deg/s; 105-140 periods an episode);
- `testbed/CmgSpinUp-v0`: the one-gyro spin-up, the observation what the single rate gyro gives.

    import gymnasium, testbed.gym
    env = gymnasium.make("testbed/CmgSlew-v0", scenario="reorient_minimax")
    # or, without the import: gymnasium.make("testbed.gym:testbed/CmgSlew-v0")
    # N worlds stepped in lockstep (testbed.gym.vector_env):
    envs = gymnasium.make_vec("testbed/CmgSlew-v0", num_envs=64, vectorization_mode="vector_entry_point")
"""

from __future__ import annotations

try:
    import gymnasium
except ImportError as exc:  # pragma: no cover - the extra is installed where the suite runs
    raise ImportError("testbed.gym needs Gymnasium: pip install 'gyrodyne-testbed[gym]'") from exc

# CmgSlewShort-v0 (docs/stepping.md "CmgSlewShort-v0"): reorient_campaign's bus and steering,
# slews of 10-30 deg about a random axis, a control period of 0.5 s (omega_n T = 0.07), the time
# limit's settling allowance 6 / omega_n (the unit PD's error falls to 2 % of e_s), tolerances of
# 1 deg and 0.1 deg/s.
SHORT_SLEW = {
    "overrides": ("sim.duration_s=120", "sim.control_period_s=0.5", "sim.trace_period_s=0.5",
                  'sweep.dispersions={"pipeline.law.angle_deg": {"uniform": [10, 30]}, '
                  '"pipeline.law.axis": {"uniform_direction": true}}'),
    "tolerance_deg": 1.0, "rate_tolerance_deg_s": 0.1, "settling_times": 6.0,
}

# id -> (entry point, native vector entry point (testbed.gym.vector_env), kwargs)
ENVIRONMENTS = {
    "testbed/CmgSlew-v0": ("testbed.gym.slew_env:CmgSlewEnv", "testbed.gym.vector_env:CmgSlewVectorEnv",
                           {"action": "torque"}),
    "testbed/CmgSlewGimbalRates-v0": ("testbed.gym.slew_env:CmgSlewEnv", "testbed.gym.vector_env:CmgSlewVectorEnv",
                                      {"action": "gimbal_rates"}),
    "testbed/CmgSlewShort-v0": ("testbed.gym.slew_env:CmgSlewEnv", "testbed.gym.vector_env:CmgSlewVectorEnv",
                                {"action": "torque", **SHORT_SLEW}),
    "testbed/CmgSpinUp-v0": ("testbed.gym.spin_up_env:CmgSpinUpEnv", "testbed.gym.vector_env:CmgSpinUpVectorEnv", {}),
}

for _id, (_entry_point, _vector_entry_point, _kwargs) in ENVIRONMENTS.items():
    if _id not in gymnasium.registry:
        gymnasium.register(id=_id, entry_point=_entry_point, vector_entry_point=_vector_entry_point, kwargs=_kwargs)
