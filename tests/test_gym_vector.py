"""Issue 41: the native vector environments (testbed/gym/vector_env.py on testbed/batch/stepped.py).

Independent numbers: Gymnasium's own SyncVectorEnv of the single environments, stepped with
the same seeds and actions. Tolerance: none, bit for bit, while every slot runs per world: a
world of the native environment then runs the same arithmetic as its single environment (its
own stages and physics; the observations, rewards and outcomes computed row by row with
reductions along the last axis only, so a row does not depend on the rows beside it). A slot
with a batched form is held to its single stage to round-off (testbed.batch.stage_forms; the
lockstep tests' 1e-9 relative over whole runs), so then the floats are compared to 1e-9
relative with a 1e-12 floor (the observations are O(1)), and the flags and statuses exactly.
"""

from __future__ import annotations

import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import testbed.gym  # noqa: F401  (registers the environments)
from testbed.batch.stage_forms import PerWorld
from testbed.errors import InputError
from testbed.gym.vector_env import CmgSlewVectorEnv, CmgSpinUpVectorEnv

# Short runs whose worlds end at different periods: a body-rate bound that random torques pass
# sooner or later (a failure, terminated) in some worlds, the scenario's end (truncated) in others.
STAGGERED = {
    "testbed/CmgSlew-v0": {"overrides": ["sim.duration_s=1.5"], "max_rate_deg_s": 0.05},
    "testbed/CmgSlewGimbalRates-v0": {"overrides": ["sim.duration_s=1.5"], "max_rate_deg_s": 0.05},
    "testbed/CmgSlewShort-v0": {"overrides": ["sim.duration_s=2", "sim.control_period_s=0.5",
                                              "sim.trace_period_s=0.5"], "max_rate_deg_s": 0.35},
    "testbed/CmgSpinUp-v0": {"overrides": ["sim.duration_s=1.5"], "max_rate_deg_s": 0.4},
}
WORLDS = 3


def made(env_id: str, mode: str, autoreset: AutoresetMode, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Gymnasium's advice on the spec
        if mode == "sync":
            return gymnasium.make_vec(env_id, num_envs=WORLDS, vectorization_mode="sync",
                                      vector_kwargs={"autoreset_mode": autoreset}, **kwargs)
        return gymnasium.make_vec(env_id, num_envs=WORLDS, vectorization_mode="vector_entry_point",
                                  autoreset_mode=autoreset, **kwargs)


def assert_same(a, b, exact: bool, what: str = "") -> None:
    """`a` equals `b`: bit for bit when `exact`, else floats to round-off (module doc)."""
    a, b = np.asarray(a), np.asarray(b)
    if exact or a.dtype.kind not in "fc":
        assert a.shape == b.shape and np.array_equal(a, b), (what, a, b)
    else:
        np.testing.assert_allclose(b, a, rtol=1e-9, atol=1e-12, err_msg=what)


def assert_infos_equal(sync: dict, native: dict, exact: bool) -> None:
    assert sorted(sync) == sorted(native)
    for key, value in sync.items():
        if key == "final_obs":
            for a, b in zip(value, native[key]):
                assert (a is None) == (b is None), key
                if a is not None:
                    assert_same(a, b, exact, key)
        elif isinstance(value, dict):
            assert_infos_equal(value, native[key], exact)
        else:
            assert_same(value, native[key], exact, key)


def every_slot_per_world(native) -> bool:
    return all(isinstance(form, PerWorld) for cohort in native.unwrapped._batch.cohorts for form in cohort.forms.values())


def run_both(env_id: str, autoreset: AutoresetMode, steps: int, seed: int):
    """Step SyncVectorEnv and the native environment side by side; the native one's batch."""
    kwargs = STAGGERED[env_id]
    sync, native = made(env_id, "sync", autoreset, **kwargs), made(env_id, "native", autoreset, **kwargs)
    rng = np.random.default_rng(seed)
    first_sync, first_native = sync.reset(seed=seed), native.reset(seed=seed)
    exact = every_slot_per_world(native)
    assert_same(first_sync[0], first_native[0], exact)
    assert_infos_equal(first_sync[1], first_native[1], exact)
    ended_any = np.zeros(WORLDS, dtype=bool)
    counts = {"terminated": 0, "truncated": 0, "cohorts": 1}
    for _ in range(steps):
        actions = rng.uniform(-1, 1, sync.action_space.shape)
        a, b = sync.step(actions), native.step(actions)
        for x, y, what in zip(a[:4], b[:4], ("observations", "rewards", "terminated", "truncated")):
            assert_same(x, y, exact, what)
        assert_infos_equal(a[4], b[4], exact)
        counts["terminated"] += int(a[2].sum())
        counts["truncated"] += int(a[3].sum())
        counts["cohorts"] = max(counts["cohorts"], len(native.unwrapped._batch.cohorts))
        ended = a[2] | a[3]
        ended_any |= ended
        if autoreset == AutoresetMode.DISABLED and ended.any():
            mask = ended.copy()
            c, d = sync.reset(options={"reset_mask": mask}), native.reset(options={"reset_mask": mask.copy()})
            assert_same(c[0], d[0], exact)
            assert_infos_equal(c[1], d[1], exact)
    sync.close()
    native.close()
    return counts


@pytest.mark.parametrize("env_id", sorted(STAGGERED))
def test_native_worlds_equal_single_environments_across_autoresets(env_id):
    # (CmgSlewShort's episodes last 4 periods here: 16 steps hold 4 of them)
    counts = run_both(env_id, AutoresetMode.NEXT_STEP, steps=16 if "Short" in env_id else 45, seed=3)
    # the run went through both endings and worlds restarted at different periods (cohorts)
    assert counts["terminated"] > 0 and counts["truncated"] > 0, counts
    assert counts["cohorts"] > 1, counts


@pytest.mark.parametrize("autoreset", [AutoresetMode.SAME_STEP, AutoresetMode.DISABLED])
def test_the_other_autoreset_modes_equal_sync_vector_env(autoreset):
    counts = run_both("testbed/CmgSpinUp-v0", autoreset, steps=40, seed=5)
    assert counts["terminated"] > 0 and counts["truncated"] > 0, counts


def test_a_worlds_seed_gives_its_episode_whatever_its_batch_mates():
    kwargs = {"overrides": ["sim.duration_s=1"]}
    rng = np.random.default_rng(1)
    actions = rng.uniform(-1, 1, (15, 3, 3))
    three = CmgSlewVectorEnv(num_envs=3, **kwargs)
    alone = CmgSlewVectorEnv(num_envs=1, **kwargs)
    first, _ = three.reset(seed=[7, 11, 13])
    again, _ = alone.reset(seed=[11])
    exact = every_slot_per_world(three)
    assert_same(first[1], again[0], exact)
    # another seed draws another slew (reorient_campaign disperses the axis and angle)
    assert not np.array_equal(first[0], first[1])
    rows = []
    for action in actions:
        obs, reward, *_ = three.step(action)
        solo, solo_reward, *_ = alone.step(action[1:2])
        assert_same(obs[1], solo[0], exact)
        assert_same(reward[1], solo_reward[0], exact)
        rows.append(obs)
    replay, _ = three.reset(seed=[7, 11, 13])   # the same seeds, the same episodes
    assert np.array_equal(replay, first)
    for action, seen in zip(actions, rows):
        assert np.array_equal(three.step(action)[0], seen)


def test_make_vec_builds_the_native_environment_for_every_id():
    for env_id, cls in (("testbed/CmgSlew-v0", CmgSlewVectorEnv), ("testbed/CmgSlewShort-v0", CmgSlewVectorEnv),
                        ("testbed/CmgSlewGimbalRates-v0", CmgSlewVectorEnv), ("testbed/CmgSpinUp-v0", CmgSpinUpVectorEnv)):
        envs = gymnasium.make_vec(env_id, num_envs=4, vectorization_mode="vector_entry_point",
                                  overrides=["sim.duration_s=1"])
        assert isinstance(envs.unwrapped, cls)
        assert envs.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
        single = envs.unwrapped.env
        assert envs.single_observation_space == single.observation_space
        assert envs.observation_space.shape == (4,) + single.observation_space.shape
        obs, info = envs.reset(seed=0)
        assert obs.shape == envs.observation_space.shape and envs.observation_space.contains(obs)
        assert list(info["status"]) == ["ok"] * 4 and not info["is_success"].any()
        envs.close()
    # without a mode, make_vec picks the vector entry point
    envs = gymnasium.make_vec("testbed/CmgSpinUp-v0", num_envs=2, overrides=["sim.duration_s=1"])
    assert isinstance(envs.unwrapped, CmgSpinUpVectorEnv)
    envs.close()


def test_bad_arguments_and_actions_are_refused():
    with pytest.raises(InputError, match="num_envs"):
        CmgSpinUpVectorEnv(num_envs=0)
    with pytest.raises(InputError, match="render_mode"):
        CmgSpinUpVectorEnv(num_envs=2, render_mode="rrd")
    with pytest.raises(InputError, match="autoreset_mode"):
        CmgSpinUpVectorEnv(num_envs=2, autoreset_mode="sometimes")
    envs = CmgSpinUpVectorEnv(num_envs=2, overrides=["sim.duration_s=1"])
    envs.reset(seed=0)
    with pytest.raises(ValueError, match=r"shape \(2, 3\)"):
        envs.step(np.zeros(3))
    with pytest.raises(ValueError, match="finite"):
        envs.step(np.full((2, 3), np.nan))
