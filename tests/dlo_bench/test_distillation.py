"""DAgger distillation of latent-mpc in the surrogate, and the policy it gives."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import dlo_env  # noqa: F401  (registers the environments)
from dlo_bench.distillation import DistillConfig, distil
from planners.distilled import DistilledPolicy, MoveNetwork, cord_frame, to_frame, to_world


def test_moves_turn_with_the_cord_frame():
    rng = np.random.default_rng(0)
    shapes = rng.normal(size=(5, 20, 2)).astype(np.float32)
    _, rotation = cord_frame(shapes)
    moves = rng.normal(size=(5, 2, 2))
    assert np.allclose(to_world(to_frame(moves, rotation), rotation), moves)


@pytest.mark.parametrize("grasp, env_id", [("head", "dlo_env/DLOEndpoint-v0"),
                                           ("both", "dlo_env/DLODualEndpoint-v0")])
def test_a_tiny_dagger_run_writes_a_network_that_acts(grasp, env_id, tmp_path):
    config = DistillConfig(grasp=grasp, difficulties=(1,), rounds=2, tasks_per_round=3,
                           horizon=2, epochs=1, width=16)
    path = distil(config, tmp_path, log=lambda _: None)
    net = MoveNetwork.load(path)
    assert net.info["real_env_steps"] == 0 and net.info["expert_plans"] >= 3
    assert [r["round"] for r in net.info["rounds"]] == [0, 1]
    env = gym.make(env_id)
    policy = DistilledPolicy.for_env(env, net)
    obs, _ = env.reset(seed=0)
    action, _ = policy.predict(obs, deterministic=True)
    assert env.action_space.contains(np.asarray(action, np.float32))
    with pytest.raises(ValueError, match="grasp"):
        DistilledPolicy.for_env(gym.make("dlo_env/DLOEndpoint-v0" if grasp == "both"
                                         else "dlo_env/DLODualEndpoint-v0"), net)
