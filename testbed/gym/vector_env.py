"""The testbed's environments as native vector environments: N worlds of one environment stepped
in lockstep by a `testbed.batch.stepped.SteppedBatch` (docs/stepping.md "Vector environments").

    import gymnasium, testbed.gym
    envs = gymnasium.make_vec("testbed/CmgSlew-v0", num_envs=64, vectorization_mode="vector_entry_point")

World i is the single environment (`single_env`, built with the same arguments) seeded as a
`SyncVectorEnv` seeds its i-th environment: the same seeds and actions give the same
observations, rewards, terminations, truncations and infos bit for bit, across autoresets.
"""

from __future__ import annotations

import gymnasium
import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from testbed.batch.physics_threads import idle_cores
from testbed.batch.stepped import SteppedBatch
from testbed.errors import InputError
from testbed.gym.slew_env import CmgSlewEnv
from testbed.gym.spin_up_env import CmgSpinUpEnv
from testbed.gym.stepped_env import SteppedEnv, case_seed, checked_actions, period_results
from testbed.run_core.plan import prepare


class SteppedVectorEnv(gymnasium.vector.VectorEnv):
    """`num_envs` worlds of `single_env(**kwargs)` (one built once for its spaces and constants),
    each episode a new run plan drawn from its own generator, as the single environment's
    `reset` draws it. `autoreset_mode`: Gymnasium's NEXT_STEP (the default: the step after a
    world's episode ends resets it, its action ignored, reward 0), SAME_STEP (reset at once, the
    ended episode's `final_obs` and `final_info` in the infos) or DISABLED (`reset(options=
    {"reset_mask": ...})` by the caller). No render mode: each world's `.rrd` is a single
    environment's (`render_mode="rrd"` through SyncVectorEnv)."""

    single_env: type[SteppedEnv]

    def __init__(self, num_envs: int = 1, autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP,
                 render_mode: str | None = None, **kwargs):
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise InputError("num_envs", f"must be a whole number >= 1, got {num_envs!r}")
        if render_mode is not None:
            raise InputError("render_mode", "a native vector environment renders nothing: for each world's .rrd "
                                            "use vectorization_mode='sync' with render_mode='rrd'")
        try:
            self.autoreset_mode = AutoresetMode(autoreset_mode)
        except ValueError:
            raise InputError("autoreset_mode", f"must be one of {[mode.value for mode in AutoresetMode]}, "
                                               f"got {autoreset_mode!r}") from None
        self.env = self.single_env(**kwargs)
        self.env.close()  # its Simulation's guards are lifted (the batch limits BLAS to one thread at each step)
        sim = self.env.sim
        if sim.plan.timing.multirate:
            raise InputError("sim.estimator_period_s", "a native vector environment steps one rate (the sensor's "
                                                       "and the law's): use vectorization_mode='sync'")
        self._episodes, self._disperses = sim.episodes, sim.disperses
        self.num_envs = int(num_envs)
        self.metadata = {"autoreset_mode": self.autoreset_mode, "render_fps": self.env.metadata["render_fps"]}
        self.single_observation_space = self.env.observation_space
        self.single_action_space = self.env.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        n = self.num_envs
        self._rngs: list = [None] * n
        self._batch: SteppedBatch | None = None
        self._episode_data: dict = {}
        self._episode_ticks = np.zeros(n, dtype=int)
        self._ended = np.zeros(n, dtype=bool)  # the episode ended at the last step (NEXT_STEP resets it)

    # --- Gymnasium's interface ---------------------------------------------------------------
    def reset(self, *, seed: int | list | None = None, options: dict | None = None):
        """Reset every world (or those of `options["reset_mask"]`, (N,) bool): seed None keeps each
        world's generator going (a new one at the first reset), an int s seeds world i with s + i,
        a list seeds each world with its own (None: keeps it)."""
        n = self.num_envs
        seeds = [None] * n if seed is None else [seed + i for i in range(n)] if isinstance(seed, int) else list(seed)
        if len(seeds) != n:
            raise ValueError(f"seed: a list of num_envs = {n} seeds, got {len(seeds)}")
        mask = np.ones(n, dtype=bool)
        if options and "reset_mask" in options:
            mask = np.asarray(options["reset_mask"])
            if mask.shape != (n,) or mask.dtype != np.bool_ or not mask.any():
                raise ValueError(f"options['reset_mask'] must be a bool array of shape ({n},) with a True value")
        if self._batch is None and not mask.all():
            raise RuntimeError("the first reset starts every world: give no reset_mask")
        rows = np.flatnonzero(mask)
        for row in rows.tolist():
            if seeds[row] is not None or self._rngs[row] is None:
                self._rngs[row], _ = seeding.np_random(seeds[row])
        self._start(rows)
        self._ended[rows] = False
        state, episodes = self._state()
        observations = self.env.observations(state, episodes)
        return observations, self._infos(state, episodes, np.zeros(n, dtype=bool), rows)

    def step(self, actions):
        n = self.num_envs
        actions = checked_actions(actions, self.single_action_space, (n,))
        batch = self._batch
        if batch is None:
            raise RuntimeError("reset() starts the worlds' episodes before the first step")
        restarted = np.flatnonzero(self._ended) if self.autoreset_mode == AutoresetMode.NEXT_STEP else np.zeros(0, int)
        if self.autoreset_mode == AutoresetMode.DISABLED and self._ended.any():
            raise RuntimeError(f"worlds {np.flatnonzero(self._ended).tolist()} ended: reset them first "
                               "(autoreset_mode DISABLED)")
        self._start(restarted)
        stepped = np.ones(n, dtype=bool)
        stepped[restarted] = False
        periods_left = self._episode_ticks - batch.ticks
        batch.step(self.env.commands(actions), stepped)
        state, episodes = self._state()
        ok = np.array([status == "ok" for status in batch.status])
        rewards, terminated, truncated, done = period_results(self.env, state, episodes, actions, ok, periods_left,
                                                              batch.ticks, self._episode_ticks)
        rewards[restarted], terminated[restarted], truncated[restarted], done[restarted] = 0.0, False, False, False
        observations = self.env.observations(state, episodes)
        infos = self._infos(state, episodes, done)
        ended = terminated | truncated
        if self.autoreset_mode == AutoresetMode.SAME_STEP and ended.any():
            rows = np.flatnonzero(ended)
            final_obs = np.full(n, None, dtype=object)
            for row in rows.tolist():
                final_obs[row] = observations[row]
            final_info = self._infos(state, episodes, done, rows)
            self._start(rows)
            state, episodes = self._state()
            observations = self.env.observations(state, episodes)
            infos = self._infos(state, episodes, done & ~ended)
            infos |= {"final_obs": final_obs, "_final_obs": ended.copy(),
                      "final_info": final_info, "_final_info": ended.copy()}
            ended = np.zeros(n, dtype=bool)
        self._ended = ended
        return observations, rewards, terminated, truncated, infos

    def close_extras(self, **kwargs) -> None:
        if self._batch is not None:
            self._batch.physics.close()
        self._batch = None

    # --- inside ------------------------------------------------------------------------------
    def _start(self, rows: np.ndarray) -> None:
        """New episodes in `rows`: each world's case seed drawn from its generator (as the single
        environment's `reset`), its plan built, and the worlds restarted together."""
        if not len(rows):
            return
        plans = [prepare(self._episodes.scenario(case_seed(self._rngs[row], self._disperses)), stepped=True)
                 for row in rows.tolist()]
        if self._batch is None or len(rows) == self.num_envs:
            if self._batch is not None:
                self._batch.physics.close()
            # alone in its process, the environment steps its worlds' physics on every core it may use
            self._batch = SteppedBatch(plans, threads=idle_cores())
        else:
            self._batch.restart(rows, plans)
        for row, plan in zip(rows.tolist(), plans):
            episode, self._episode_ticks[row] = self.env.started(plan)
            for key, value in episode.items():
                if key not in self._episode_data:
                    self._episode_data[key] = np.zeros((self.num_envs,) + np.shape(value))
                self._episode_data[key][row] = value

    def _state(self) -> tuple[dict, dict]:
        return self.env.read(self._batch.plants), self._episode_data

    def _infos(self, state: dict, episodes: dict, done: np.ndarray, rows: np.ndarray | None = None) -> dict:
        """The worlds' infos as Gymnasium's vector environments give them ({key: (N,) values, "_key":
        (N,) which worlds have it}): each world's single-environment info (`SteppedEnv._info`), of
        the worlds at `rows` only (None: all)."""
        n, batch = self.num_envs, self._batch
        timing = batch.timing
        times = np.array([timing.time_after(int(ticks)) if status == "ok" else plant.time
                          for ticks, status, plant in zip(batch.ticks, batch.status, batch.plants)])
        values = {"time_s": times, "status": np.array(batch.status, dtype=object), "is_success": done.copy()}
        values |= self.env.details(state, episodes)
        present = np.ones(n, dtype=bool) if rows is None else np.isin(np.arange(n), rows)
        infos = {}
        for key, value in values.items():
            if rows is not None:  # absent rows as Gymnasium's vector infos hold them: None or 0
                value = np.where(present, value, None if value.dtype == object else np.zeros((), value.dtype))
                value = value.astype(values[key].dtype)
            infos[key], infos[f"_{key}"] = value, present.copy()
        return infos


class CmgSlewVectorEnv(SteppedVectorEnv):
    """`testbed/CmgSlew-v0`, `CmgSlewGimbalRates-v0` and `CmgSlewShort-v0` as vector environments."""

    single_env = CmgSlewEnv


class CmgSpinUpVectorEnv(SteppedVectorEnv):
    """`testbed/CmgSpinUp-v0` as a vector environment."""

    single_env = CmgSpinUpEnv
