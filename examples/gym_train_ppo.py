"""Train a small PPO agent on CmgSlewShort-v0 and report its learning curve and success rate.

    pip install 'gyrodyne-testbed[rl]'          # stable-baselines3 and torch (CPU), pinned
    nice python examples/gym_train_ppo.py       # its CPU time: docs/validation.md "Measured times"

The agent (stable-baselines3's PPO, one CPU thread) learns the slew of `testbed/CmgSlewShort-v0`
(slews of 10-30 deg, tolerances 1 deg and 0.1 deg/s): a linear policy (the unit PD is one) and
a 64-64 value function. The learner's reward is the environment's plus potential-based shaping
(`PotentialShaping`, which leaves the optimal policies unchanged), normalised (`VecNormalize`:
the success bonus is a hundred times a period's cost); the observation is already scaled by
the environment. `--algorithm sac|td3` tries stable-baselines3's off-policy learners instead.
Written:

- `runs/ppo_learning_curve.csv` (a run's output, not committed): per block of training steps,
  the episodes that ended in it, the share that succeeded (the stochastic policy, as it trained) and their mean return
  (the environment's own, without the shaping);
- `docs/images/ppo_learning_curve.svg`: the success share against the training steps;
- printed: each training episode as it ends; the trained policy's success rate, acting
  deterministically, on the fixed evaluation seeds, beside the unit-gain PD's on the same seeds.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import gymnasium
import numpy as np

import testbed.gym  # noqa: F401  (registers testbed/CmgSlewShort-v0)

ENV_ID = "testbed/CmgSlewShort-v0"
DOCS_IMAGES = Path(__file__).resolve().parents[1] / "docs" / "images"
CURVE_TABLE = Path(__file__).resolve().parents[1] / "runs" / "ppo_learning_curve.csv"
EVALUATION_SEEDS = range(1000, 1020)   # never used in training (training draws from seed 0's stream)
GAMMA = 0.99
BLOCK_STEPS = 1000                     # the learning curve's resolution


class PotentialShaping(gymnasium.Wrapper):
    """The environment's reward plus gamma phi(s') - phi(s), phi = -(|e| / e_s + |omega| / omega_s):
    potential-based shaping (Ng, Harada and Russell 1999) leaves the optimal policies as they
    are, and gives the learner a slope toward the target before it has ever reached it."""

    def __init__(self, env, gamma: float):
        super().__init__(env)
        self.gamma = gamma

    def _phi(self, observation) -> float:
        scales = self.env.unwrapped.scales
        error = float(np.linalg.norm(observation[-3:])) * np.pi
        return -(error / scales.error + float(np.linalg.norm(observation[3:6])))

    def reset(self, **kwargs):
        observation, info = self.env.reset(**kwargs)
        self.phi = self._phi(observation)
        return observation, info

    def step(self, action):
        observation, reward, terminated, truncated, info = self.env.step(action)
        phi = 0.0 if terminated else self._phi(observation)  # an end state has no future
        reward += self.gamma * phi - self.phi
        self.phi = phi
        return observation, reward, terminated, truncated, info


def train(steps: int, algorithm: str = "ppo", seed: int = 0, shaping: bool = False):
    """(model, episodes): the agent trained for `steps` environment steps; episodes: (steps at
    its end, success, return) of each training episode, in order."""
    import torch
    from stable_baselines3 import PPO, SAC, TD3
    from stable_baselines3.common.callbacks import BaseCallback
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    torch.set_num_threads(1)  # a small MLP: threads cost more than they give
    episodes = []

    class Episodes(BaseCallback):
        def _on_step(self) -> bool:
            for info in self.locals["infos"]:
                if "episode" in info:
                    episodes.append((self.num_timesteps, bool(info["is_success"]), float(info["episode"]["r"])))
                    print(f"episode {len(episodes)} at {self.num_timesteps} steps: success {info['is_success']}, "
                          f"return {info['episode']['r']:.1f}, error {info['attitude_error_deg']:.2f} deg",
                          flush=True)
            return True

    def make():
        env = Monitor(gymnasium.make(ENV_ID), info_keywords=("is_success",))  # the environment's own return
        return PotentialShaping(env, GAMMA) if shaping else env

    envs = DummyVecEnv([make])
    envs.seed(seed)
    envs = VecNormalize(envs, norm_obs=False, norm_reward=True, gamma=GAMMA)
    if algorithm == "ppo":
        # a linear policy (the unit PD is one) and a 64-64 value function
        model = PPO("MlpPolicy", envs, n_steps=512, batch_size=64, n_epochs=10, gamma=GAMMA, gae_lambda=0.95,
                    learning_rate=1e-3, policy_kwargs={"net_arch": {"pi": [], "vf": [64, 64]}, "log_std_init": -1.0},
                    seed=seed, device="cpu", verbose=0)
    else:
        learner = SAC if algorithm == "sac" else TD3
        extra = {"ent_coef": "auto_0.1"} if algorithm == "sac" else {}
        model = learner("MlpPolicy", envs, learning_starts=1000, batch_size=128, buffer_size=steps, gamma=GAMMA,
                        learning_rate=1e-3, policy_kwargs={"net_arch": [64, 64]}, seed=seed, device="cpu", verbose=0,
                        **extra)
    model.learn(total_timesteps=steps, callback=Episodes())
    return model, episodes


def success_rate(policy, seeds=EVALUATION_SEEDS) -> float:
    """The share of `seeds` whose episode `policy(observation) -> action` ends at the target."""
    env = gymnasium.make(ENV_ID)
    successes = 0
    for seed in seeds:
        observation, _ = env.reset(seed=seed)
        while True:
            observation, _, terminated, truncated, info = env.step(policy(observation))
            if terminated or truncated:
                successes += info["is_success"]
                break
    env.close()
    return successes / len(seeds)


def learning_curve(episodes, steps: int, block: int = BLOCK_STEPS) -> list[dict]:
    """Per block of `block` training steps: the episodes ended in it, their success share and mean return."""
    rows = []
    for start in range(0, steps, block):
        inside = [(s, r) for t, s, r in episodes if start < t <= start + block]
        if inside:
            rows.append({"steps": start + block, "episodes": len(inside),
                         "success_rate": round(float(np.mean([s for s, _ in inside])), 4),
                         "mean_return": round(float(np.mean([r for _, r in inside])), 2)})
    return rows


def curve_svg(rows: list[dict], steps: int, final: float) -> str:
    """The success share against the training steps, as a small SVG line chart."""
    width, height, left, bottom, top, right = 640, 360, 60, 50, 30, 20
    plot_w, plot_h = width - left - right, height - top - bottom

    def x(s):
        return left + plot_w * s / steps

    def y(v):
        return top + plot_h * (1.0 - v)

    points = " ".join(f"{x(r['steps']):.1f},{y(r['success_rate']):.1f}" for r in rows)
    ticks = "".join(f'<line x1="{left}" x2="{left + plot_w}" y1="{y(v):.1f}" y2="{y(v):.1f}" stroke="#ddd"/>'
                    f'<text x="{left - 8}" y="{y(v) + 4:.1f}" text-anchor="end">{v:.2f}</text>'
                    for v in (0.0, 0.25, 0.5, 0.75, 1.0))
    xticks = "".join(f'<text x="{x(s):.1f}" y="{top + plot_h + 18}" text-anchor="middle">{s // 1000}k</text>'
                     for s in range(0, steps + 1, max(steps // 5, 1)))
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
            f'font-family="sans-serif" font-size="12">'
            f'<rect width="{width}" height="{height}" fill="white"/>{ticks}{xticks}'
            f'<polyline points="{points}" fill="none" stroke="#1f77b4" stroke-width="2"/>'
            f'<line x1="{left}" x2="{left + plot_w}" y1="{y(final):.1f}" y2="{y(final):.1f}" '
            f'stroke="#d62728" stroke-dasharray="6 4"/>'
            f'<text x="{left + plot_w}" y="{y(final) - 6:.1f}" text-anchor="end" fill="#d62728">'
            f'trained policy, deterministic: {final:.0%} of {len(EVALUATION_SEEDS)} fixed seeds</text>'
            f'<text x="{left + plot_w / 2}" y="{height - 10}" text-anchor="middle">training steps (control periods, 0.5 s each)</text>'
            f'<text x="16" y="{top + plot_h / 2}" text-anchor="middle" transform="rotate(-90 16 {top + plot_h / 2})">'
            f'share of training episodes that succeed [-]</text>'
            f'<text x="{left}" y="18">PPO on {ENV_ID}: success while training (per {BLOCK_STEPS} steps)</text></svg>\n')


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=80_000, help="training steps (control periods)")
    parser.add_argument("--algorithm", choices=("ppo", "sac", "td3"), default="ppo")
    parser.add_argument("--no-shaping", dest="shaping", action="store_false",
                        help="train on the environment's reward alone (without PotentialShaping)")
    parser.add_argument("--out", type=Path, default=DOCS_IMAGES, help="where the SVG goes")
    parser.add_argument("--table", type=Path, default=CURVE_TABLE, help="the learning curve's CSV")
    args = parser.parse_args(argv)
    model, episodes = train(args.steps, args.algorithm, shaping=args.shaping)
    trained = success_rate(lambda o: model.predict(o, deterministic=True)[0])
    plain_pd = success_rate(lambda o: np.clip(o[0:3] - o[3:6], -1.0, 1.0))
    rows = learning_curve(episodes, args.steps)
    args.out.mkdir(parents=True, exist_ok=True)
    args.table.parent.mkdir(parents=True, exist_ok=True)
    with open(args.table, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=["steps", "episodes", "success_rate", "mean_return"])
        writer.writeheader()
        writer.writerows(rows)
    (args.out / "ppo_learning_curve.svg").write_text(curve_svg(rows, args.steps, trained))
    for row in rows:
        print(f"{row['steps']:>8d} steps: {row['episodes']:3d} episodes, success {row['success_rate']:.2f}, "
              f"mean return {row['mean_return']:.1f}")
    print(f"after {args.steps} steps ({len(episodes)} episodes): the trained policy succeeds on {trained:.0%} "
          f"of {len(EVALUATION_SEEDS)} fixed seeds (the unit-gain PD: {plain_pd:.0%})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
