"""Specification: the environments pass Gymnasium's and SB3's checkers and run vectorised."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gymnasium_check_env

import dlo_env  # noqa: F401  (registers the environments)

IDS = ["dlo_env/DLOEndpoint-v0", "dlo_env/DLODualEndpoint-v0"]
#: The learned twins, checked by the same checkers (they need torch).
SURROGATE_IDS = ["dlo_env/DLOEndpointSurrogate-v0", "dlo_env/DLODualEndpointSurrogate-v0"]


def warnings_of(check, *args, **kwargs) -> list[str]:
    """Run a checker and return every warning it raised (none are filtered out)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check(*args, **kwargs)
    return [f"{w.category.__name__}: {w.message}" for w in caught]


@pytest.mark.parametrize("env_id", IDS + SURROGATE_IDS)
@pytest.mark.parametrize("render_mode", [None, "rgb_array"])
def test_gymnasium_check_env_passes_without_warnings(env_id, render_mode):
    # Gymnasium's checker wants the bare environment (it warns about wrappers otherwise).
    env = gym.make(env_id, render_mode=render_mode).unwrapped
    assert warnings_of(gymnasium_check_env, env, skip_render_check=render_mode is None) == []


@pytest.mark.parametrize("env_id", IDS + SURROGATE_IDS)
def test_stable_baselines3_check_env_passes_without_warnings(env_id):
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    # SB3 2.x looks up ``compute_reward`` directly on the object it is given, which Gymnasium
    # 1.x wrappers no longer forward, so the checker is given the bare environment; SB3's HER
    # and vector envs reach it through the wrappers with ``get_wrapper_attr`` (tested below).
    env = gym.make(env_id).unwrapped
    assert warnings_of(sb3_checker.check_env, env, warn=True) == []


def test_compute_reward_is_reachable_through_the_gym_make_wrappers():
    env = gym.make(IDS[0])
    obs, _ = env.reset(seed=0)
    obs, reward, *_ = env.step(np.ones(2, np.float32))
    compute_reward = env.get_wrapper_attr("compute_reward")
    assert compute_reward(obs["achieved_goal"], obs["desired_goal"], {}) == reward


@pytest.mark.parametrize("env_id", IDS)
def test_async_vector_env_steps_like_the_single_envs(env_id):
    envs = gym.make_vec(env_id, num_envs=2, vectorization_mode="async")
    singles = [gym.make(env_id) for _ in range(2)]
    try:
        obs, info = envs.reset(seed=[3, 4])
        assert obs["desired_goal"].shape == (2, 40) and info["is_success"].tolist() == [0, 0]
        rng = np.random.default_rng(0)
        actions = rng.uniform(-1, 1, (5, *envs.action_space.shape)).astype(np.float32)
        for a in actions:
            obs, reward, terminated, truncated, info = envs.step(a)
        for i, (env, seed) in enumerate(zip(singles, (3, 4))):
            env.reset(seed=seed)
            for a in actions:
                single_obs, single_reward, *_ = env.step(a[i])
            assert np.array_equal(obs["achieved_goal"][i], single_obs["achieved_goal"])
            assert reward[i] == single_reward
    finally:
        envs.close()


@pytest.mark.slow
def test_stable_baselines3_subproc_vec_env_runs_the_env_with_its_default_start_method():
    vec_env = pytest.importorskip("stable_baselines3.common.vec_env")
    env_util = pytest.importorskip("stable_baselines3.common.env_util")
    # SB3 starts workers as fresh interpreters (forkserver) that have not imported dlo_env:
    # the "module:id" form makes gym.make import the package, which registers the ids.
    envs = env_util.make_vec_env(f"dlo_env:{IDS[0]}", n_envs=2, seed=0,
                                 vec_env_cls=vec_env.SubprocVecEnv)
    try:
        obs = envs.reset()
        assert obs["observation"].shape == (2, 42)
        assert not np.array_equal(obs["desired_goal"][0], obs["desired_goal"][1])
        for _ in range(3):
            obs, rewards, dones, infos = envs.step(np.ones((2, 2), np.float32))
        assert rewards.shape == (2,) and all("is_success" in i for i in infos)
        # HER relabels through env_method: the reward must match the step's.
        relabelled = envs.env_method("compute_reward", obs["achieved_goal"],
                                     obs["desired_goal"], infos, indices=[0])[0]
        np.testing.assert_array_equal(relabelled, rewards)
    finally:
        envs.close()
