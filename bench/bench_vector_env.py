"""CmgSlew-v0's env-steps per second: the native vector environment (testbed.gym.vector_env,
N worlds in lockstep) against Gymnasium's SyncVectorEnv of N single environments (issue 41;
goal >= 10x).

At each N both are made and reset with the same seeds, then stepped by the same policy for
`--steps` vector steps (both see the same observations bit for bit, so they take the same
actions; resets inside are counted: NEXT_STEP autoreset); each
way's wall time over N x steps gives env-steps/s. The two alternate `--repeat` times and the
fastest of each counts. Prints a row per N and the ratio native / sync, and which slots ran
through a batched form and which per world.

    .venv/bin/python bench/bench_vector_env.py [--sizes 16 64 256] [--steps 200] [--policy pd|random]
"""

import argparse
import time
import warnings

import gymnasium
import numpy as np

import testbed.gym  # noqa: F401  (registers the environments)
from testbed.batch.stage_forms import PerWorld


def pd_action(observations: np.ndarray) -> np.ndarray:
    """The unit PD a = o_e - o_w of CmgSlew's scaled observation (docs/stepping.md "Scaling"),
    clipped to the action space: smooth commands, as a trained policy gives."""
    return np.clip(observations[:, 0:3] - observations[:, 3:6], -1.0, 1.0)


def rate(envs, steps: int, seed: int, policy: str) -> float:
    """Env-steps per second of `envs` reset with `seed` and stepped `steps` times by `policy`
    ("pd": `pd_action`; "random": uniform actions, a command jump every period)."""
    observations, _ = envs.reset(seed=seed)
    rng = np.random.default_rng(seed)
    start = time.perf_counter()
    for _ in range(steps):
        action = pd_action(observations) if policy == "pd" else rng.uniform(-1, 1, envs.action_space.shape)
        observations = envs.step(action)[0]
    return steps * envs.num_envs / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--env", default="testbed/CmgSlew-v0", choices=("testbed/CmgSlew-v0", "testbed/CmgSlewShort-v0"))
    parser.add_argument("--sizes", type=int, nargs="+", default=[16, 64, 256])
    parser.add_argument("--steps", type=int, default=200, help="vector steps at each N")
    parser.add_argument("--repeat", type=int, default=1, help="alternations; the fastest of each counts")
    parser.add_argument("--policy", choices=("pd", "random"), default="pd",
                        help="pd: smooth commands; random: a jump every period (the physics refines each)")
    args = parser.parse_args()
    print(f"{args.env}: env-steps/s, {args.steps} vector steps of the {args.policy} policy at each N, "
          f"best of {args.repeat}")
    print(f"{'N':>5} {'native':>10} {'sync':>10} {'ratio':>7}")
    for n in args.sizes:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # Gymnasium's advice on the spec
            native = gymnasium.make_vec(args.env, num_envs=n, vectorization_mode="vector_entry_point")
            sync = gymnasium.make_vec(args.env, num_envs=n, vectorization_mode="sync")
        best = {"native": 0.0, "sync": 0.0}
        for _ in range(args.repeat):
            for name, envs in (("native", native), ("sync", sync)):
                best[name] = max(best[name], rate(envs, args.steps, n, args.policy))
        print(f"{n:>5} {best['native']:>10.0f} {best['sync']:>10.0f} {best['native'] / best['sync']:>7.2f}")
        forms = native.unwrapped._batch.cohorts[0].forms
        native.close()
        sync.close()
    print("slots: " + ", ".join(f"{slot} {'per world' if isinstance(form, PerWorld) else 'batched'}"
                                for slot, form in forms.items()))


if __name__ == "__main__":
    main()
