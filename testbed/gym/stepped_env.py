"""What the testbed's Gymnasium environments share: a `testbed.Simulation` stepped one control
period per `step`, Gymnasium's seeding, truncation at the scenario's duration, an episode
ended by a failed run, and `render_mode="rrd"` (docs/stepping.md "Gymnasium environments").

A subclass sets `observation_space` and `action_space` and says what an action commands
(`command`), what is observed (`observation`), what a period costs (`reward`) and when the
task is done or failed (`outcome`).
"""

from __future__ import annotations

from pathlib import Path

import gymnasium
import numpy as np

from testbed.recording.output_paths import file_stem
from testbed.stepping.simulation import Simulation


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

    # --- what a subclass says ----------------------------------------------------------------
    def command(self, action: np.ndarray) -> dict:
        """The `Simulation.step` command of an action (already clipped to the action space)."""
        raise NotImplementedError

    def observation(self) -> np.ndarray:
        raise NotImplementedError

    def reward(self, action: np.ndarray) -> float:
        raise NotImplementedError

    def outcome(self) -> tuple[bool, bool]:
        """(done, failed) at the state now."""
        raise NotImplementedError

    def details(self) -> dict:
        """What `info` adds to the time and the run's status."""
        return {}

    def episode_started(self) -> None:
        """Design data of the episode just built (its drawn target, ...)."""

    def time_limit_ticks(self) -> int:
        """The control periods the episode just started may last (called after `episode_started`);
        more than the scenario's are cut to the scenario's."""
        return self.sim.n_ticks

    # --- Gymnasium's interface -------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        case_seed = int(self.np_random.integers(2**32))
        self.sim.reset(seed=case_seed if self.sim.disperses else None)
        self.episode_started()
        self.episode_ticks = min(self.time_limit_ticks(), self.sim.n_ticks)
        return self.observation(), self._info(False)

    def step(self, action):
        if np.iscomplexobj(action):  # float64 of it would drop the imaginary part, with a warning
            raise ValueError(f"the action must be a finite real array of shape {self.action_space.shape}, got {action!r}")
        action = np.asarray(action, dtype=np.float64)
        if action.shape != self.action_space.shape or not np.all(np.isfinite(action)):
            raise ValueError(f"the action must be a finite array of shape {self.action_space.shape}, got {action!r}")
        action = np.clip(action, self.action_space.low, self.action_space.high)
        periods_left = self.episode_ticks - self.sim.ticks
        self.sim.step(self.command(action))
        if self.sim.status != "ok":
            done, failed = False, True
        else:
            done, failed = self.outcome()
        reward = self.reward(action)
        if done and not failed:
            reward += self.success_bonus()
        if failed:
            reward -= self.failure_cost_per_period * (periods_left - 1)
        terminated = done or failed
        truncated = not terminated and self.sim.ticks >= self.episode_ticks
        return self.observation(), float(reward), terminated, truncated, self._info(done)

    def render(self):
        """Nothing to return: with render_mode "rrd" the episode's trace goes to `rrd_path`."""
        return None

    def close(self):
        self.sim.close()
        super().close()

    def success_bonus(self) -> float:
        """What a success earns at once: the most the whole episode could cost (class doc)."""
        return self.failure_cost_per_period * self.episode_ticks

    def _info(self, done: bool) -> dict:
        return {"time_s": self.sim.time, "status": self.sim.status, "is_success": bool(done)} | self.details()
