"""Specification: behaviour cloning trains on the Minari demonstrations, records its sample cost
and acts as the registered ``bc`` agent."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

import dlo_env  # noqa: F401  (registers the environments)
from dlo_bench.agents import build_agent
from dlo_bench.paths import shipped_baseline

pytest.importorskip("stable_baselines3", reason='needs the rl extra: pip install -e ".[rl]"')
pytest.importorskip("minari", reason='needs the minari extra: pip install -e ".[minari]"')

from dlo_bench.behaviour_cloning import BCConfig, load_bc, train_bc  # noqa: E402
from dlo_env.dataset.minari_export import export_demonstrations  # noqa: E402


@pytest.fixture(scope="module")
def demonstrations(tmp_path_factory):
    """Two small oracle datasets of DLOEndpoint-v0 in a private Minari root."""
    root = tmp_path_factory.mktemp("minari")
    exported = [export_demonstrations("dlo_env/DLOEndpoint-v0", suite, root=root, limit=4)
                for suite in ("linear-1", "linear-2")]
    return root, exported


def test_bc_trains_on_the_demonstrations_and_records_their_steps_as_sample_cost(
        demonstrations, tmp_path):
    root, exported = demonstrations
    config = BCConfig(datasets=tuple(d.dataset_id for d in exported), root=str(root), epochs=2,
                      batch_size=16, net_arch=(32,))
    model_path = train_bc(config, tmp_path / "bc")
    meta = json.loads((tmp_path / "bc" / "hyperparameters.json").read_text())
    assert model_path.is_file() and meta["algo"] == "bc"
    assert meta["trained_timesteps"] == sum(d.steps for d in exported)
    assert meta["demonstration_episodes"] == 8 and meta["environment_interaction_steps"] == 0
    assert BCConfig.from_dict(meta["config"]) == config
    env = gym.make("dlo_env/DLOEndpoint-v0")
    policy = build_agent("bc", env, baseline=tmp_path / "bc")
    obs, _ = env.reset(seed=0)
    action, _ = policy.predict(obs, deterministic=True)
    assert action.shape == (2,) and np.all(np.abs(action) <= 1)


def test_a_missing_dataset_names_the_command_that_writes_it(tmp_path):
    with pytest.raises(FileNotFoundError, match="dlo export-minari"):
        train_bc(BCConfig(datasets=("dlo/endpoint/linear-9-oracle-v0",), root=str(tmp_path)),
                 tmp_path / "bc")


def test_load_bc_refuses_a_folder_of_another_algorithm():
    with pytest.raises(ValueError, match="no behaviour-cloning model"):
        load_bc(shipped_baseline("ppo"))


def test_the_shipped_bc_agent_acts_in_the_endpoint_environment():
    env = gym.make("dlo_env/DLOEndpoint-v0")
    obs, _ = env.reset(seed=1)
    action, _ = build_agent("bc", env).predict(obs, deterministic=True)
    assert action.shape == (2,)


def test_the_shipped_bc_agents_act_in_both_environments_and_refuse_the_other():
    env = gym.make("dlo_env/DLODualEndpoint-v0")
    obs, _ = env.reset(seed=1)
    action, _ = build_agent("bc", env).predict(obs, deterministic=True)
    assert action.shape == (4,)
    with pytest.raises(ValueError, match="cloned in dlo_env/DLOEndpoint-v0, not"):
        load_bc(shipped_baseline("bc"), env_id="dlo_env/DLODualEndpoint-v0")
    with pytest.raises(ValueError, match="cloned in dlo_env/DLODualEndpoint-v0, not"):
        build_agent("bc", gym.make("dlo_env/DLOEndpoint-v0"),
                    baseline=shipped_baseline("bc", "dlo_env/DLODualEndpoint-v0"))
