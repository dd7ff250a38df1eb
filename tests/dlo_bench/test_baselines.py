"""The baselines: agents by name, the physics-in-the-loop planner, SB3 training and loading."""

from __future__ import annotations

import json
import shutil
import tempfile

import gymnasium as gym
import numpy as np
import pytest

import dlo_env  # noqa: F401  (registers the environments)
from dlo_bench import build_agent, evaluate
from dlo_bench.baselines import (
    BaselineConfig,
    RandomDifficulty,
    load_baseline,
    read_baseline_metadata,
    read_monitor_logs,
    train_baseline,
)
from dlo_bench.policy_file import POLICY_FILE
from dlo_env.tasks import load_suite
from planners.physics_mpc import PhysicsMPCConfig, PhysicsMPCPolicy

ENV_ID = "dlo_env/DLOEndpoint-v0"
#: A tiny run: the plumbing, not the learning, is tested.
TINY = dict(timesteps=256, n_envs=1, net_arch=(16, 16), ppo_n_steps=128, ppo_batch_size=64,
            ppo_epochs=1, sac_buffer_size=1000, sac_batch_size=32, sac_learning_starts=150,
            checkpoint_every=128)


def _actions(policy, episodes=1, difficulty=2, steps=30):
    """Actions of ``policy`` over the first steps of some episodes."""
    env = gym.make(ENV_ID)
    out = []
    for seed in range(episodes):
        obs, _ = env.reset(seed=seed, options={"difficulty": difficulty})
        if hasattr(policy, "reset"):
            policy.reset()
        for t in range(steps):
            action, _ = policy.predict(obs, episode_start=np.array([t == 0]),
                                       deterministic=True)
            out.append(np.asarray(action))
            obs, _, terminated, truncated, _ = env.step(np.asarray(action).reshape(-1))
            if terminated or truncated:
                break
    return np.array(out)


def _assert_within_bounds(actions, dim=2):
    assert actions.ndim == 2 and actions.shape[1] == dim and len(actions) >= 1
    assert np.isfinite(actions).all()
    assert (np.abs(actions) <= 1.0 + 1e-6).all()


@pytest.fixture(scope="module")
def tiny_models(tmp_path_factory):
    """A tiny PPO and a tiny SAC + HER baseline folder, trained once for the module."""
    root = tmp_path_factory.mktemp("baselines")
    for algo in ("ppo", "sac-her"):
        train_baseline(BaselineConfig(algo=algo, **TINY), root / algo, progress_bar=False)
    return root


def test_straight_line_agent_acts_within_bounds():
    env = gym.make(ENV_ID)
    _assert_within_bounds(_actions(build_agent("straight-line", env), episodes=2))


def test_latent_tree_agents_act_within_bounds_on_a_toy_model(toy_model):
    env = gym.make(ENV_ID)
    for name in ("latent-tree", "latent-tree-closed"):
        policy = build_agent(name, env, model=toy_model, replan_every=5)
        _assert_within_bounds(_actions(policy, steps=12))
        assert policy.stats.plans >= 1


def test_unknown_agent_name_is_rejected():
    with pytest.raises(ValueError, match="agent name must be one of"):
        build_agent("teleport", gym.make(ENV_ID))


def test_physics_mpc_matches_the_environment_and_acts_within_bounds():
    env = gym.make(ENV_ID, max_step=0.03)
    policy = build_agent("physics-mpc", env, seed=3)
    assert isinstance(policy, PhysicsMPCPolicy)
    assert policy.max_step == 0.03 and policy.grasp == "head" and policy.config.seed == 3
    cheap = PhysicsMPCPolicy.for_env(env, PhysicsMPCConfig(samples=4, elites=2, iterations=1))
    obs, _ = env.reset(seed=0, options={"difficulty": 2})
    action, _ = cheap.predict(obs)
    assert action.shape == (2,) and action.dtype == np.float32
    assert (np.abs(action) <= 1.0).all()
    assert cheap.stats.plans == 1 and cheap.stats.rollouts == 4
    batched, _ = cheap.predict({k: v[None] for k, v in obs.items()})
    assert batched.shape == (1, 2)


def test_physics_mpc_config_rejects_more_elites_than_samples():
    with pytest.raises(ValueError, match="elites"):
        PhysicsMPCConfig(samples=4, elites=5)


def test_physics_mpc_plan_is_same_for_same_seed():
    env = gym.make(ENV_ID)
    obs, _ = env.reset(seed=1, options={"difficulty": 1})
    n = env.unwrapped.params.n_points
    shape, goal = obs["achieved_goal"].reshape(n, 2), obs["desired_goal"].reshape(n, 2)
    config = PhysicsMPCConfig(samples=6, elites=2, iterations=1, seed=7)
    plans = [PhysicsMPCPolicy.for_env(env, config).plan(shape, goal) for _ in range(2)]
    np.testing.assert_array_equal(plans[0][0], plans[1][0])
    assert plans[0][1] == plans[1][1]


@pytest.mark.slow
def test_physics_mpc_solves_easy_tasks():
    tasks = load_suite("linear-1", "test", limit=2)
    policy = build_agent("physics-mpc", gym.make(ENV_ID))
    result = evaluate(policy, ENV_ID, suite="linear-1", episodes=len(tasks), fidelity=False)
    assert result.summary["success_rate"] == 1.0
    assert all(r.plans >= 1 and r.planning_seconds > 0 for r in result.records)


def test_random_difficulty_draws_only_the_given_difficulties_and_repeats_with_a_seed():
    env = RandomDifficulty(gym.make(ENV_ID), (2, 3), seed=0)
    drawn = [env.reset(seed=5 if i == 0 else None)[1]["difficulty"] for i in range(6)]
    again = [env.reset(seed=5 if i == 0 else None)[1]["difficulty"] for i in range(6)]
    assert set(drawn) <= {2, 3} and drawn == again
    assert env.reset(options={"difficulty": 1})[1]["difficulty"] == 1


def test_random_cords_draw_train_cords_from_a_stream_of_their_own():
    from dlo_bench.baselines import RandomCords, _make_env
    from dlo_env import CordParams
    from dlo_env.randomize import DEFAULT_RANGES, draw_train_cord, near_test_cords

    env = RandomCords(gym.make(ENV_ID), seed=0)
    drawn = [env.reset(seed=5 if i == 0 else None)[1]["params"] for i in range(6)]
    again = [env.reset(seed=5 if i == 0 else None)[1]["params"] for i in range(6)]
    assert drawn == again and len(set(drawn)) == 6
    rows = [[getattr(p, k) for k in DEFAULT_RANGES] for p in drawn]
    assert not near_test_cords(rows, tuple(DEFAULT_RANGES)).any()
    # not the stream the environment and RandomDifficulty draw from with the same seed
    assert drawn[0] != draw_train_cord(CordParams(), np.random.default_rng(5))
    told = CordParams(mass=0.2)
    assert env.reset(options={"params": told})[1]["params"] == told
    plain = _make_env(BaselineConfig(), 0, None)
    assert plain.reset(seed=1)[1]["params"] == CordParams()  # --cords fixed: the env's cord
    trained = _make_env(BaselineConfig(cords="train"), 0, None)
    assert trained.reset(seed=1)[1]["params"] != CordParams()


def test_baseline_config_rejects_bad_settings():
    with pytest.raises(ValueError, match="algo"):
        BaselineConfig(algo="dqn")
    with pytest.raises(ValueError, match="sac_learning_starts"):
        BaselineConfig(algo="sac-her", n_envs=2, sac_learning_starts=150)
    with pytest.raises(ValueError, match="difficulties"):
        BaselineConfig(difficulties=(0,))
    with pytest.raises(ValueError, match="unknown keys"):
        BaselineConfig.from_dict({"algo": "ppo", "learning_rte": 1e-3})
    with pytest.raises(ValueError, match="cords must be one of"):
        BaselineConfig(cords="random")


@pytest.mark.slow
@pytest.mark.parametrize("algo", ["ppo", "sac-her"])
def test_training_writes_model_hyperparameters_logs_and_curve_and_reloads(tiny_models, algo):
    folder = tiny_models / algo
    for name in ("model.zip", "hyperparameters.json", "learning_curve.png"):
        assert (folder / name).is_file()
    assert not (folder / "checkpoint.zip").exists()  # removed once the model is saved
    meta = read_baseline_metadata(folder)
    assert meta["config"]["algo"] == algo and meta["trained_timesteps"] >= TINY["timesteps"]
    assert BaselineConfig.from_dict(meta["config"]) == BaselineConfig(algo=algo, **TINY)
    logs = read_monitor_logs(folder / "monitor")
    assert len(logs["length"]) >= 1 and logs["timesteps"][-1] <= meta["trained_timesteps"]
    model = load_baseline(folder)
    assert model.num_timesteps == meta["trained_timesteps"]
    with pytest.raises(ValueError, match="trained with --cords fixed, not --cords train"):
        load_baseline(folder, cords="train")
    _assert_within_bounds(_actions(model, steps=10))
    agent = build_agent(f"sb3:{folder}", gym.make(ENV_ID))
    obs, _ = gym.make(ENV_ID).reset(seed=0)
    np.testing.assert_array_equal(agent.predict(obs, deterministic=True)[0],
                                  model.predict(obs, deterministic=True)[0])


@pytest.mark.slow
def test_a_folder_with_the_acting_weights_alone_acts_as_its_model(tiny_models, tmp_path):
    for algo in ("ppo", "sac-her"):
        shipped = tmp_path / algo  # as dlo_bench/pretrained/ holds them: no model.zip
        shutil.copytree(tiny_models / algo, shipped, ignore=shutil.ignore_patterns("model.zip"))
        assert (shipped / POLICY_FILE).stat().st_size < 0.6 * (
            tiny_models / algo / "model.zip").stat().st_size
        full, alone = load_baseline(tiny_models / algo), load_baseline(shipped)
        env = gym.make(ENV_ID)
        obs, _ = env.reset(seed=1)
        for _ in range(5):
            action = full.predict(obs, deterministic=True)[0]
            np.testing.assert_array_equal(alone.predict(obs, deterministic=True)[0], action)
            obs = env.step(action)[0]
        other = "sac-her" if algo == "ppo" else "ppo"
        shutil.copy(tiny_models / other / POLICY_FILE, shipped / POLICY_FILE)
        with pytest.raises(ValueError, match="weights of another policy"):
            load_baseline(shipped)


@pytest.mark.slow
def test_training_resumes_from_a_checkpoint(tiny_models, tmp_path):
    folder = tmp_path / "ppo"
    shutil.copytree(tiny_models / "ppo", folder)
    shutil.copy(folder / "model.zip", folder / "checkpoint.zip")  # as if interrupted at 256
    config = BaselineConfig(algo="ppo", **{**TINY, "timesteps": 384})
    with pytest.raises(ValueError, match="resume needs the config"):
        train_baseline(BaselineConfig(algo="ppo", **{**TINY, "seed": 1}), folder,
                       progress_bar=False, resume=True)
    json_run = json.loads((folder / "run.json").read_text())
    assert json_run["config"]["seed"] == 0  # a refused resume leaves the run untouched
    train_baseline(config, folder, progress_bar=False, resume=True)
    meta = read_baseline_metadata(folder)
    assert meta["resumed_at"] == 256 and meta["trained_timesteps"] >= 384


def test_training_leaves_no_log_folder_in_the_temp_dir(tmp_path, monkeypatch):
    temp = tmp_path / "temp"
    temp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temp))
    monkeypatch.delenv("SB3_LOGDIR", raising=False)
    folder = tmp_path / "ppo"
    train_baseline(BaselineConfig(algo="ppo", **{**TINY, "timesteps": 128}), folder,
                   progress_bar=False)
    shutil.copy(folder / "model.zip", folder / "checkpoint.zip")
    train_baseline(BaselineConfig(algo="ppo", **{**TINY, "timesteps": 256}), folder,
                   progress_bar=False, resume=True)
    assert list(temp.iterdir()) == []  # SB3's default logger would leave SB3-<time> folders


def test_load_baseline_names_a_folder_without_a_model(tmp_path):
    with pytest.raises(FileNotFoundError, match="baseline folder"):
        load_baseline(tmp_path)


def test_a_baseline_can_train_where_pegs_are_observed():
    from dlo_bench.baselines import BaselineConfig, make_vec_env

    env = make_vec_env(BaselineConfig(max_pegs=2, n_envs=1))
    assert env.observation_space["observation"].shape == (42 + 6,)
    env.reset()
    assert len(env.envs[0].unwrapped.pegs) <= 2
    env.close()
    with pytest.raises(ValueError, match="max_pegs must be an int from 0 to"):
        BaselineConfig(max_pegs=-1)
