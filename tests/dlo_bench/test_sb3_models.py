"""sb3:PATH takes any Stable-Baselines3 model: a dlo baseline folder, a model.zip, rl-zoo3."""

from __future__ import annotations

import json
import shutil
from collections import OrderedDict

import gymnasium as gym
import numpy as np
import pytest

import dlo_env  # noqa: F401  (registers the environments)

pytest.importorskip("stable_baselines3")
from stable_baselines3 import PPO  # noqa: E402

from dlo_bench import build_agent  # noqa: E402
from dlo_bench.paths import shipped_baseline  # noqa: E402
from dlo_bench.sb3_models import FlatObservationPolicy, find_sb3  # noqa: E402

ENV = "dlo_env/DLOEndpoint-v0"


@pytest.fixture(scope="module")
def plain_zip(tmp_path_factory):
    path = tmp_path_factory.mktemp("sb3") / "agent.zip"
    PPO("MultiInputPolicy", gym.make(ENV), n_steps=32, batch_size=32).save(path)
    return path


def _acts(agent, env_id=ENV):
    env = gym.make(env_id)
    policy = build_agent(agent, env)
    obs, _ = env.reset(seed=0)
    action, _ = policy.predict(obs, deterministic=True)
    assert env.action_space.contains(np.asarray(action, dtype=np.float32))
    return policy


def test_a_plain_model_zip_acts_and_its_training_is_unknown(plain_zip):
    source = find_sb3(plain_zip)
    assert (source.algo, source.her, source.kind, source.env_id) == ("PPO", False,
                                                                     "model.zip", None)
    assert "trained in unknown, episodes ending at unknown" in source.describe()
    _acts(f"sb3:{plain_zip}")


def test_a_policy_of_flattened_observations_acts_through_the_flattening_wrapper(tmp_path):
    flat = gym.wrappers.FlattenObservation(gym.make(ENV))
    PPO("MlpPolicy", flat, n_steps=32, batch_size=32).save(tmp_path / "flat.zip")
    policy = _acts(f"sb3:{tmp_path / 'flat.zip'}")
    assert isinstance(policy, FlatObservationPolicy)
    obs, _ = gym.make(ENV).reset(seed=0)
    assert np.array_equal(policy.flatten(obs), gym.spaces.flatten(
        gym.make(ENV).observation_space, obs))


def test_a_model_of_the_other_environment_is_refused_in_one_line(plain_zip):
    with pytest.raises(ValueError, match="action space"):
        build_agent(f"sb3:{plain_zip}", gym.make("dlo_env/DLODualEndpoint-v0"))


def test_an_rl_zoo3_run_folder_gives_its_environment_and_threshold(plain_zip, tmp_path):
    import yaml

    run = tmp_path / "ppo" / "dlo_env-DLOEndpoint-v0_1"
    params = run / "dlo_env-DLOEndpoint-v0"
    params.mkdir(parents=True)
    shutil.copy(plain_zip, run / "dlo_env-DLOEndpoint-v0.zip")
    # rl-zoo3 dumps OrderedDicts (ExperimentManager._save_config)
    (params / "args.yml").write_text(yaml.dump(OrderedDict([("algo", "ppo"), ("env", ENV)])))
    (params / "config.yml").write_text(yaml.dump(OrderedDict(
        [("env_kwargs", {"success_threshold": 0.01}), ("n_envs", 2)])))
    source = find_sb3(run)
    assert (source.kind, source.env_id, source.training_threshold) == ("rl-zoo3", ENV, 0.01)
    _acts(f"sb3:{run}")
    (params / "vecnormalize.pkl").write_bytes(b"")  # trained on normalised observations
    with pytest.raises(ValueError, match="normalised observations"):
        find_sb3(run)


def test_a_baseline_folder_whose_metadata_disagrees_with_its_model_is_refused(tmp_path):
    folder = tmp_path / "run"
    shutil.copytree(shipped_baseline("ppo"), folder)
    meta = json.loads((folder / "hyperparameters.json").read_text())
    meta["config"]["algo"] = "sac-her"
    (folder / "hyperparameters.json").write_text(json.dumps(meta))
    assert find_sb3(folder).model_file.name == "policy.pt"  # shipped: the acting weights alone
    with pytest.raises(ValueError, match="weights of another policy"):
        build_agent(f"sb3:{folder}", gym.make(ENV))
    PPO("MultiInputPolicy", gym.make(ENV), n_steps=32, batch_size=32).save(folder / "model.zip")
    with pytest.raises(ValueError, match="says sac-her, but model.zip holds a PPO"):
        find_sb3(folder)


def test_a_shipped_baseline_folder_acts_as_an_sb3_agent():
    folder = shipped_baseline("ppo")
    assert not (folder / "model.zip").exists()
    source = find_sb3(folder)
    assert (source.algo, source.her, source.kind) == ("PPO", False, "dlo baseline")
    env = gym.make(ENV)
    obs, _ = env.reset(seed=0)
    np.testing.assert_array_equal(build_agent(f"sb3:{folder}", env).predict(obs)[0],
                                  build_agent("ppo", env).predict(obs)[0])


def test_the_shipped_baselines_describe_their_training():
    source = find_sb3(shipped_baseline("sac-her"))
    assert (source.algo, source.her, source.env_id) == ("SAC", True, ENV)
    assert source.training_threshold == 0.02


def test_a_path_without_a_model_is_refused_naming_what_sb3_takes(tmp_path):
    with pytest.raises(FileNotFoundError, match="holds no model.zip"):
        find_sb3(tmp_path)
    (tmp_path / "junk.zip").write_text("not a zip")
    with pytest.raises(ValueError, match="not a Stable-Baselines3 model zip"):
        find_sb3(tmp_path / "junk.zip")
