"""What the testbed's Gymnasium environments share: a `testbed.Simulation` stepped one control
period per `step`, Gymnasium's seeding, truncation at the scenario's duration, an episode
ended by a failed run, and `render_mode="rrd"` (docs/stepping.md "Gymnasium environments").

A subclass sets `observation_space` and `action_space` and says, on (N, ...) arrays of N
worlds (a row each: the single environment is the row of a batch of one, and the vector
environment, testbed.gym.vector_env, every row at once), what an action commands (`commands`),
what of a world's plant the task reads (`read`), what is observed (`observations`), what a
period costs (`rewards`) and when the task is done or failed (`outcomes`). Every reduction
along a row is a sum along the last axis, so that a row's numbers do not depend on the rows
beside it: a world of the vector environment is its single environment bit for bit.
"""

from __future__ import annotations

from pathlib import Path

import gymnasium
import numpy as np

from testbed.recording.output_paths import file_stem
from testbed.stepping.simulation import Simulation


def case_seed(generator: np.random.Generator, disperses: bool) -> int | None:
    """An episode's case seed in [0, 2^32), drawn from the environment's generator (drawn whether
    or not the scenario `disperses`, so that the generator's stream is the same either way; None
    when nothing disperses)."""
    seed = int(generator.integers(2**32))
    return seed if disperses else None


def norms(values) -> np.ndarray:
    """|v| of each row of `values` (..., k): the sum of squares along the last axis, rooted."""
    values = np.asarray(values, dtype=np.float64)
    return np.sqrt(np.sum(values * values, axis=-1))


def checked_actions(actions, space: gymnasium.spaces.Box, rows: tuple = ()) -> np.ndarray:
    """`actions` (rows + the space's shape) as finite float64, clipped to the space; anything
    else is refused (ValueError naming the shape wanted)."""
    shape = rows + space.shape
    if np.iscomplexobj(actions):  # float64 of it would drop the imaginary part, with a warning
        raise ValueError(f"the action must be a finite real array of shape {shape}, got {actions!r}")
    actions = np.asarray(actions, dtype=np.float64)
    if actions.shape != shape or not np.all(np.isfinite(actions)):
        raise ValueError(f"the action must be a finite array of shape {shape}, got {actions!r}")
    return np.clip(actions, space.low, space.high)


def period_results(env: "SteppedEnv", state: dict, episodes: dict, actions: np.ndarray, ok: np.ndarray,
                   periods_left: np.ndarray, ticks: np.ndarray, episode_ticks: np.ndarray):
    """(rewards, terminated, truncated, done) (N,) of a control period just run by N worlds of
    `env`'s task: `ok` whether a world's run is still sound (a run that diverged or failed is
    failed), `periods_left` its episode's periods before this one ran, `ticks` after it
    (`SteppedEnv`: the success bonus and the failure cost)."""
    done, failed = env.outcomes(state, episodes)
    failed = failed | ~ok
    done = done & ok
    rewards = env.rewards(state, episodes, actions)
    cost = env.failure_cost_per_period
    rewards = (rewards + np.where(done & ~failed, cost * episode_ticks, 0.0)  # `SteppedEnv.success_bonus`
               - np.where(failed, cost * (periods_left - 1), 0.0))
    terminated = done | failed
    return rewards, terminated, ~terminated & (ticks >= episode_ticks), done


class SteppedEnv(gymnasium.Env):
    """One episode = one run of `scenario` (a name, path or mapping, with `overrides`).

    reset(seed): Gymnasium's generator (`np_random`) is seeded, and a case seed in [0, 2^32)
    drawn from it sets the scenario's campaign dispersions, when it has any (its
    `sweep.dispersions`: e.g. reorient_campaign's slew axis and angle): the same seed, the
    same episode bit for bit. step(action): one control period. The episode is truncated at
    its time limit (`time_limit_ticks`: the scenario's duration unless the subclass sets a
    shorter one for the episode drawn), and terminated when the task is done or has failed
    (the run diverged, a stage failed, or the subclass's own bounds); a failure costs
    `failure_cost_per_period` times the periods left, and a success earns `success_bonus()`:
    `failure_cost_per_period` (the most a period can cost) times the episode's periods (its
    time limit), so that every episode that succeeds returns at least 0 and more than every
    episode that does not (whose costs sum to at most 0), and, of two successes, the sooner
    returns more when their periods cost alike (docs/stepping.md "Reward"). render_mode
    "rrd": each episode's trace
    is written to `rrd_path` (default `runs/<scenario>.episode.rrd`), whole once the episode
    ends (at the next reset or at close)."""

    metadata = {"render_modes": ["rrd"]}
    failure_cost_per_period = 1.0

    def __init__(self, scenario, overrides=(), render_mode: str | None = None, rrd_path: str | Path | None = None):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}")
        self.render_mode = render_mode
        out = None
        if render_mode == "rrd":
            name = scenario.get("name", "run") if isinstance(scenario, dict) else Path(str(scenario)).stem
            out = rrd_path if rrd_path is not None else Path("runs") / f"{file_stem(str(name))}.episode.rrd"
        self.sim = Simulation(scenario, list(overrides), out=out, keep_trace=False)
        self.rrd_path = out
        sim = self.sim.scenario.sim
        self.metadata = dict(self.metadata, render_fps=1.0 / sim.control_period_s)
        self.control_period_s = sim.control_period_s
        self.episode_ticks = self.sim.n_ticks
        self.episode: dict = {}  # the episode's data (`episode_of`)

    # --- what a subclass says, on (N, ...) arrays of N worlds ------------------------------------
    def commands(self, actions: np.ndarray) -> dict:
        """slot -> {key: (N, ...)}: what the actions (N, ...) (clipped to the action space) give
        each world's slots (`Simulation.step`'s command, a row per world)."""
        raise NotImplementedError

    def read(self, plants: list) -> dict:
        """{name: (N, ...)}: what the task reads of the worlds' plants now."""
        raise NotImplementedError

    def observations(self, state: dict, episodes: dict) -> np.ndarray:
        """(N, ...) observations of the state read (`read`) in the worlds' episodes (`episode_of`, stacked)."""
        raise NotImplementedError

    def rewards(self, state: dict, episodes: dict, actions: np.ndarray) -> np.ndarray:
        """(N,) what the period just run earned."""
        raise NotImplementedError

    def outcomes(self, state: dict, episodes: dict) -> tuple[np.ndarray, np.ndarray]:
        """(done, failed) (N,) at the state read."""
        raise NotImplementedError

    def details(self, state: dict, episodes: dict) -> dict:
        """{name: (N,)}: what `info` adds to the time and the run's status."""
        return {}

    def episode_of(self, plan) -> dict:
        """{name: array}: what the task needs of an episode just built (its drawn target, ...), from
        its run plan (testbed.run_core.plan.RunPlan: plant and pipeline at t = 0)."""
        return {}

    def time_limit_ticks(self, plan, episode: dict) -> int:
        """The control periods the episode just started may last; more than the scenario's are cut
        to the scenario's."""
        return plan.timing.n_ticks

    def started(self, plan) -> tuple[dict, int]:
        """(the episode's data, its time limit in control periods) of an episode just built from `plan`."""
        episode = self.episode_of(plan)
        return episode, min(self.time_limit_ticks(plan, episode), plan.timing.n_ticks)

    # --- Gymnasium's interface -------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.sim.reset(seed=case_seed(self.np_random, self.sim.disperses))
        self.episode, self.episode_ticks = self.started(self.sim.plan)
        return self.observation(), self._info(False)

    def step(self, action):
        actions = checked_actions(action, self.action_space)[None]
        periods_left = self.episode_ticks - self.sim.ticks
        self.sim.step({slot: {key: values[0] for key, values in command.items()}
                       for slot, command in self.commands(actions).items()})
        state, episodes = self._state()
        rewards, terminated, truncated, done = period_results(
            self, state, episodes, actions, np.array([self.sim.status == "ok"]), np.array([periods_left]),
            np.array([self.sim.ticks]), np.array([self.episode_ticks]))
        return (self.observations(state, episodes)[0], float(rewards[0]), bool(terminated[0]), bool(truncated[0]),
                self._info(bool(done[0]), state, episodes))

    def observation(self) -> np.ndarray:
        """The observation now."""
        return self.observations(*self._state())[0]

    def render(self):
        """Nothing to return: with render_mode "rrd" the episode's trace goes to `rrd_path`."""
        return None

    def close(self):
        self.sim.close()
        super().close()

    def success_bonus(self) -> float:
        """What a success earns at once: the most the whole episode could cost (class doc)."""
        return self.failure_cost_per_period * self.episode_ticks

    def _state(self) -> tuple[dict, dict]:
        """(what the task reads now, the episode's data), each a batch of one world."""
        return self.read([self.sim.plant]), {key: np.asarray(value)[None] for key, value in self.episode.items()}

    def _info(self, done: bool, state: dict | None = None, episodes: dict | None = None) -> dict:
        if state is None:
            state, episodes = self._state()
        details = {key: float(values[0]) for key, values in self.details(state, episodes).items()}
        return {"time_s": self.sim.time, "status": self.sim.status, "is_success": bool(done)} | details
