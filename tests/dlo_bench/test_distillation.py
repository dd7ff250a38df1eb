"""DAgger distillation of latent-mpc in the surrogate, and the policy it gives."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import dlo_env  # noqa: F401  (registers the environments)
from dlo_bench.agents import build_agent
from dlo_bench.distillation import STATE_FILE, DistillConfig, distil
from planners.distilled import (
    MIN_MOVE,
    DistilledConfig,
    DistilledPolicy,
    MoveNetwork,
    cord_frame,
    features,
    mirrored,
    to_frame,
    to_world,
)


def test_plans_turn_with_the_cord_frame():
    rng = np.random.default_rng(0)
    shapes = rng.normal(size=(5, 20, 2)).astype(np.float32)
    _, rotation = cord_frame(shapes)
    plans = rng.normal(size=(5, 3, 2, 2))
    assert np.allclose(to_world(to_frame(plans, rotation), rotation, 2), plans)


def test_a_mirrored_task_has_the_mirrored_features_and_plan():
    rng = np.random.default_rng(1)
    shapes = np.cumsum(rng.normal(scale=0.02, size=(4, 20, 2)), axis=1).astype(np.float32)
    goals = shapes + rng.normal(scale=0.05, size=(4, 1, 2)).astype(np.float32)
    plans = rng.normal(scale=0.1, size=(4, 5, 1, 2))
    flip = np.array([1.0, -1.0], dtype=np.float32)
    x, rotation = features(shapes, goals)
    xm, rotation_m = features(shapes * flip, goals * flip)
    assert np.allclose(mirrored(x), xm, atol=1e-6)
    assert np.allclose(mirrored(to_frame(plans, rotation)), to_frame(plans * flip, rotation_m),
                       atol=1e-9)


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
    policy = build_agent("latent-mpc-distilled", env, baseline=tmp_path)
    assert isinstance(policy, DistilledPolicy)
    obs, _ = env.reset(seed=0)
    action, _ = policy.predict(obs, deterministic=True)
    assert env.action_space.contains(np.asarray(action, np.float32))
    steps, cost = policy.training_cost()
    assert steps == 0 and "latent-mpc plans" in cost
    with pytest.raises(ValueError, match="grasp"):
        DistilledPolicy.for_env(gym.make("dlo_env/DLOEndpoint-v0" if grasp == "both"
                                         else "dlo_env/DLODualEndpoint-v0"), net)


def test_a_run_resumes_after_its_last_round_and_refuses_another_config(tmp_path):
    config = DistillConfig(difficulties=(1,), rounds=1, tasks_per_round=3, horizon=1,
                           epochs=1, width=16)
    distil(config, tmp_path, log=lambda _: None)
    assert (tmp_path / STATE_FILE).is_file()
    lines: list[str] = []
    path = distil(DistillConfig(**{**config.__dict__, "rounds": 2}), tmp_path, log=lines.append)
    assert lines[0].startswith("resuming after round 0")
    assert [r["round"] for r in MoveNetwork.load(path).info["rounds"]] == [0, 1]
    with pytest.raises(ValueError, match="another distillation"):
        distil(DistillConfig(**{**config.__dict__, "width": 8}), tmp_path, log=lambda _: None)


def test_a_symmetric_network_answers_a_mirrored_task_with_the_mirrored_plan():
    rng = np.random.default_rng(2)
    shapes = np.cumsum(rng.normal(scale=0.02, size=(3, 20, 2)), axis=1).astype(np.float32)
    goals = shapes + rng.normal(scale=0.05, size=(3, 1, 2)).astype(np.float32)
    flip = np.array([1.0, -1.0], dtype=np.float32)
    net = MoveNetwork(DistilledConfig(width=8))
    assert np.allclose(net.plans(shapes * flip, goals * flip), net.plans(shapes, goals) * flip,
                       atol=1e-6)
    net = MoveNetwork(DistilledConfig(width=8, symmetric=False))  # an untrained one is not
    assert not np.allclose(net.plans(shapes * flip, goals * flip),
                           net.plans(shapes, goals) * flip, atol=1e-3)


def test_the_policy_executes_every_real_move_of_the_plan_each_followed_by_rest():
    net = MoveNetwork(DistilledConfig(moves=3, width=8))
    policy = DistilledPolicy(net, 0.01)
    policy.reset()
    zero = np.zeros(2, np.float32)
    plan = np.array([[[0.05, 0.0]], [[MIN_MOVE / 2, 0.0]], [[0.0, -0.03]]])
    actions = policy._execute(plan)  # noqa: SLF001
    moving = [a for a in actions if np.any(a)]
    assert np.allclose(np.sum(moving, axis=0) * policy.max_step, [0.05, -0.03])
    settle = policy.config.settle_actions
    assert all(np.array_equal(a, zero) for a in actions[-settle:])
    # a plan of still moves only: its first move is still made (the policy never idles)
    assert np.any(policy._execute(np.full((3, 1, 2), MIN_MOVE / 4)))  # noqa: SLF001


def test_the_agent_without_a_network_says_how_to_make_one(tmp_path):
    with pytest.raises(FileNotFoundError, match="dlo distil --env dlo_env/DLOEndpoint-v0"):
        build_agent("latent-mpc-distilled", gym.make("dlo_env/DLOEndpoint-v0"),
                    baseline=tmp_path)
