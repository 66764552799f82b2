"""A classical controller through CmgSlew-v0, and the same controller as a plug-in scenario.

    python examples/gym_slew_classical.py

The plain PD with unit gains of examples/slew_pd_policy.py flies reorient_minimax's 60 deg slew
through `gymnasium.make("testbed/CmgSlew-v0")` (torque action, min-max steering) until the
episode ends at the target (within 0.01 deg and 0.002 deg/s); then the same policy, as the
plug-in law `examples.slew_pd`, runs the same scenario for the same time with
`testbed.run`. The attitude, rate and torques of the two agree bit for bit (printed).
Under 30 s (about 2 s on one core).
"""

from __future__ import annotations

import copy
import sys
from pathlib import Path

import gymnasium
import numpy as np

import testbed
import testbed.gym  # noqa: F401  (registers testbed/CmgSlew-v0)
from testbed.scenario.loading import load_mapping

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from slew_pd_policy import PlainPD  # noqa: E402


def fly_the_env(scenario: str = "reorient_minimax", seed: int = 0) -> dict:
    """One episode of the policy through the environment: what it ended with."""
    env = gymnasium.make("testbed/CmgSlew-v0", scenario=scenario)
    observation, _ = env.reset(seed=seed)
    slew = env.unwrapped
    policy = PlainPD()
    torques, steps = [], 0
    while True:
        action = policy(observation)
        torques.append(action * slew.scales.torque)
        observation, _, terminated, truncated, info = env.step(action)
        steps += 1
        if terminated or truncated:
            break
    ended = {"steps": steps, "terminated": terminated, "info": info, "torques": np.array(torques),
             "quat": slew.sim.plant.quat(), "omega": slew.sim.plant.omega(), "target": slew.target,
             "scales": slew.scales}
    env.close()
    return ended


def run_the_plugin(ended: dict, scenario: str = "reorient_minimax") -> testbed.RunResult:
    """The same policy as the plug-in law `examples.slew_pd`, the scenario cut at the episode's end."""
    data, _ = load_mapping(scenario)
    data = copy.deepcopy(data)
    period = data["sim"]["control_period_s"]
    data["plugins"] = [str(HERE / "slew_pd_policy.py")]
    data["sim"]["duration_s"] = ended["steps"] * period
    data["pipeline"]["law"] = {"type": "examples.slew_pd", "target_quat": ended["target"].tolist(),
                               "error_scale_rad": ended["scales"].error, "rate_scale_rad_s": ended["scales"].rate,
                               "torque_scale_nm": ended["scales"].torque}
    data["checks"] = {}
    return testbed.run(data)


def main() -> int:
    ended = fly_the_env()
    info = ended["info"]
    print(f"env: {ended['steps']} periods to t = {info['time_s']:.2f} s, terminated {ended['terminated']}, "
          f"error {info['attitude_error_deg']:.6f} deg, rate {info['rate_deg_s']:.6f} deg/s")
    result = run_the_plugin(ended)
    quat, omega = result.trace["truth/quat"][1][-1], result.trace["truth/omega"][1][-1]
    torques = result.trace["law/torque"][1]
    same = (np.array_equal(quat, ended["quat"]) and np.array_equal(omega, ended["omega"])
            and np.array_equal(torques, ended["torques"]))
    print(f"plug-in: status {result.status}, {len(torques)} torques, final quat {quat.tolist()}")
    print(f"the same numbers bit for bit: {same}")
    return 0 if same and ended["terminated"] and info["attitude_error_deg"] <= 0.01 else 1


if __name__ == "__main__":
    raise SystemExit(main())
