"""Gymnasium environments of the testbed (docs/stepping.md "Gymnasium environments"), built on
`testbed.Simulation`; this package needs the optional extra `gym` (Gymnasium).

Importing it registers, under Gymnasium's namespace `testbed`:

- `testbed/CmgSlew-v0`: a rest-to-rest slew of the four-CMG bus, the action the body torque
  wanted (the scenario's own steering turns it into gimbal rates);
- `testbed/CmgSlewGimbalRates-v0`: the same slew, the action the gimbal rates themselves;
- `testbed/CmgSpinUp-v0`: the one-gyro spin-up, the observation what the single rate gyro gives.

    import gymnasium, testbed.gym
    env = gymnasium.make("testbed/CmgSlew-v0", scenario="reorient_minimax")
    # or, without the import: gymnasium.make("testbed.gym:testbed/CmgSlew-v0")
"""

from __future__ import annotations

try:
    import gymnasium
except ImportError as exc:  # pragma: no cover - the extra is installed where the suite runs
    raise ImportError("testbed.gym needs Gymnasium: pip install 'gyrodyne-testbed[gym]'") from exc

ENVIRONMENTS = {
    "testbed/CmgSlew-v0": ("testbed.gym.slew_env:CmgSlewEnv", {"action": "torque"}),
    "testbed/CmgSlewGimbalRates-v0": ("testbed.gym.slew_env:CmgSlewEnv", {"action": "gimbal_rates"}),
    "testbed/CmgSpinUp-v0": ("testbed.gym.spin_up_env:CmgSpinUpEnv", {}),
}

for _id, (_entry_point, _kwargs) in ENVIRONMENTS.items():
    if _id not in gymnasium.registry:
        gymnasium.register(id=_id, entry_point=_entry_point, kwargs=_kwargs)
