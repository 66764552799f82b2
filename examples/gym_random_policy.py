"""A random policy on CmgSlew-v0 and CmgSpinUp-v0: the interface, the rewards and the seeding.

    python examples/gym_random_policy.py

Each environment runs 200 control periods of uniform random actions (the action space's own
generator, seeded), twice from the same seed: the returns are printed, and equal. Under 30 s.
"""

from __future__ import annotations

import gymnasium
import numpy as np

import testbed.gym  # noqa: F401  (registers the environments)


def rollout(env_id: str, seed: int, periods: int = 200) -> tuple[float, np.ndarray]:
    """(sum of rewards, last observation) of `periods` random actions from reset(seed)."""
    env = gymnasium.make(env_id)
    observation, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    total = 0.0
    for _ in range(periods):
        observation, reward, terminated, truncated, _ = env.step(env.action_space.sample())
        total += reward
        if terminated or truncated:
            break
    env.close()
    return total, observation


def main() -> int:
    same = True
    for env_id in ("testbed/CmgSlew-v0", "testbed/CmgSpinUp-v0"):
        first, again = rollout(env_id, seed=1), rollout(env_id, seed=1)
        repeated = first[0] == again[0] and np.array_equal(first[1], again[1])
        same &= repeated
        print(f"{env_id}: return {first[0]:.6f} over 200 random periods, repeated bit for bit: {repeated}")
    return 0 if same else 1


if __name__ == "__main__":
    raise SystemExit(main())
