"""SB3VecEnv: a same-step Gymnasium vector env as Stable-Baselines3's VecEnv."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import dlo_env  # noqa: F401  (registers the environments)

pytest.importorskip("stable_baselines3")
from dlo_bench.sb3_vec_env import SB3VecEnv  # noqa: E402

ID = "dlo_env/DLOEndpointSurrogate-v0"


def make(num_envs=4, **kwargs):
    venv = gym.make_vec(ID, num_envs=num_envs, vectorization_mode="vector_entry_point",
                        autoreset_mode="same_step", device="cpu", **kwargs)
    return SB3VecEnv(venv)


def test_an_ended_episode_reports_its_last_step_and_observation():
    env = make()
    env.reset()
    first, _ = env.venv.reset(seed=0)
    shapes = first["achieved_goal"]  # goals where the cords are: the first step succeeds
    obs, _ = env.venv.reset(options={"start": shapes, "goal": shapes})
    new, reward, done, infos = env.step(np.zeros((4, 2), np.float32))
    assert done.all()
    for i, info in enumerate(infos):
        assert info["is_success"] and not info["TimeLimit.truncated"]
        assert np.array_equal(info["terminal_observation"]["achieved_goal"],
                              obs["achieved_goal"][i])  # a zero action: the cord stayed
        assert not np.array_equal(new["desired_goal"][i], obs["desired_goal"][i])


def test_a_time_limit_is_a_truncation():
    env = make(success_threshold=1e-9, max_episode_steps=2)
    env.reset()
    env.step(np.zeros((4, 2), np.float32))
    _, _, done, infos = env.step(np.zeros((4, 2), np.float32))
    assert done.all() and all(i["TimeLimit.truncated"] and not i["is_success"] for i in infos)


def test_compute_reward_reaches_the_batch_as_her_calls_it():
    env = make()
    obs = env.reset()
    rewards = env.env_method("compute_reward", obs["achieved_goal"], obs["desired_goal"],
                             [{}] * 4, indices=[0])
    assert len(rewards) == 1 and rewards[0].shape == (4,) and (rewards[0] < 0).all()


def test_a_next_step_vector_env_is_refused():
    venv = gym.make_vec(ID, num_envs=2, vectorization_mode="vector_entry_point", device="cpu")
    with pytest.raises(ValueError, match="same_step"):
        SB3VecEnv(venv)


@pytest.mark.parametrize("algo", ["ppo", "sac-her"])
def test_sb3_trains_on_the_batch(algo):
    from stable_baselines3 import PPO, SAC, HerReplayBuffer

    env = make(8, max_episode_steps=10)
    if algo == "ppo":
        model = PPO("MultiInputPolicy", env, n_steps=16, batch_size=64, n_epochs=1)
    else:
        model = SAC("MultiInputPolicy", env, replay_buffer_class=HerReplayBuffer,
                    learning_starts=100, batch_size=32)
    model.learn(256)
    assert model.num_timesteps >= 256


def test_the_train_in_surrogate_example_trains_and_scores_in_pymunk(tmp_path, monkeypatch,
                                                                     capsys):
    from scripts import load_script

    example = load_script("examples/train_in_surrogate.py")
    monkeypatch.setattr("sys.argv", ["train_in_surrogate.py", "--timesteps", "512",
                                     "--num-envs", "64", "--episodes", "1",
                                     "--out", str(tmp_path)])
    example.main()
    out = capsys.readouterr().out
    assert (tmp_path / "model.zip").is_file()
    assert "surrogate steps (0 pymunk steps)" in out and "in pymunk, linear-1" in out
