"""grad-mpc: plans descended through the differentiable transition model."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import dlo_env  # noqa: F401  (registers the environments)
from dlo_bench import build_agent
from dlo_env.tasks import load_suite
from planners.grad_mpc import GradMPCConfig, GradMPCPolicy


def test_gradient_steps_improve_on_the_candidates_they_start_from():
    env = gym.make("dlo_env/DLOEndpoint-v0")
    assert isinstance(build_agent("grad-mpc", env), GradMPCPolicy)
    task = load_suite("linear-2", "train", limit=1)[0]
    start, goal = task.start.astype(np.float64), task.goal.astype(np.float64)
    errors = {}
    for steps, rate in ((1, 1e-9), (40, 0.01)):  # the start candidates alone; then descended
        config = GradMPCConfig(grad_steps=steps, learning_rate=rate, stop_fraction=0.0)
        policy = GradMPCPolicy.for_env(env, config)
        errors[steps] = policy.plan(start, goal)[1]
        assert policy.stats.rollouts == (steps + 1) * config.samples
    assert errors[40] < 0.7 * errors[1]


def test_grad_mpc_solves_a_one_move_task_in_the_simulator():
    env = gym.make("dlo_env/DLODualEndpoint-v0")
    policy = build_agent("grad-mpc", env)
    obs, info = env.reset(options={"task": load_suite("linear-1", "test", grasp="both")[0]})
    for _ in range(60):
        action, _ = policy.predict(obs, deterministic=True)
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    assert info["is_success"]


def test_config_is_checked():
    with pytest.raises(ValueError, match="grad_steps"):
        GradMPCConfig(grad_steps=0)
    with pytest.raises(ValueError, match="learning_rate"):
        GradMPCConfig(learning_rate=-1.0)
