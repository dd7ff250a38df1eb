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


def test_grad_mpc_told_a_designed_suites_cord_descends_through_that_cord():
    """On the letters cord grad-mpc plans on the model of that cord, and its differentiable
    step predicts what ``predict`` does for the told cord (not the model's own)."""
    import torch

    from dlo_bench.agents import model_files
    from dlo_env.designed_suites import designed_suite_cord

    env = gym.make("dlo_env/DLODualEndpoint-v0", params=designed_suite_cord("shapes-letters"))
    policy = build_agent("grad-mpc", env)
    assert policy.cord == env.unwrapped.params and policy.dynamics.params == policy.cord
    assert model_files("grad-mpc", env)[0].endswith("transition-letters.pt")
    bare = GradMPCPolicy.for_env(env, GradMPCConfig(projection_iterations=0), model=policy.model)
    shape = env.reset(seed=0)[0]["achieved_goal"].reshape(-1, 2)
    move = np.array([[0.05, 0.02, -0.03, 0.04]], dtype=np.float32)
    with torch.no_grad():
        stepped = bare.dynamics.step(torch.as_tensor(shape[None]), torch.as_tensor(move))
    told = policy.model.predict(shape[None], "both", move, params=policy.cord, inextensible=False)
    own = policy.model.predict(shape[None], "both", move, inextensible=False)
    np.testing.assert_allclose(stepped.numpy(), told, atol=1e-4)
    assert np.abs(told - own).max() > 1e-3  # the told cord is not the model's own


def test_config_is_checked():
    with pytest.raises(ValueError, match="grad_steps"):
        GradMPCConfig(grad_steps=0)
    with pytest.raises(ValueError, match="learning_rate"):
        GradMPCConfig(learning_rate=-1.0)


def test_latent_mpc_polish_takes_a_better_plan_only():
    """latent-mpc's polish: the search's best plan, descended, replaces it only where the
    search's own scoring predicts the result better; a search that already reaches the goal
    is not polished."""
    from planners.latent_mpc import LatentMPCConfig, LatentMPCPolicy

    env = gym.make("dlo_env/DLOEndpoint-v0", success_threshold=0.005)
    task = load_suite("linear-3", "train", limit=1)[0]
    start, goal = task.start.astype(np.float64), task.goal.astype(np.float64)
    weak = dict(samples=8, elites=2, iterations=1, stop_fraction=0.5)  # a search that misses
    plain = LatentMPCPolicy.for_env(env, LatentMPCConfig(**weak, polish_steps=0))
    polished = LatentMPCPolicy.for_env(env, LatentMPCConfig(**weak, polish_steps=30))
    plan, error = plain.plan(start, goal)
    better, better_error = polished.plan(start, goal)
    assert error > 0.5 * 0.005  # the search alone is not predicted within the stop
    assert better_error < error
    assert not np.allclose(plan, better)
    assert better_error == pytest.approx(polished._score(start, goal, better[None])[0])
    assert polished.stats.rollouts > plain.stats.rollouts
    done = LatentMPCPolicy.for_env(env, LatentMPCConfig(**weak, polish_steps=30))
    near = load_suite("linear-1", "train", limit=1)[0]
    _, done_error = done.plan(near.goal.astype(np.float64), near.goal.astype(np.float64))
    assert done_error <= 0.5 * 0.005
    assert done.stats.rollouts == 8  # one iteration, no polish


def test_latent_mpc_polish_config_is_checked():
    from planners.latent_mpc import LatentMPCConfig

    with pytest.raises(ValueError, match="polish_steps"):
        LatentMPCConfig(polish_steps=-1)
    with pytest.raises(ValueError, match="polish_samples"):
        LatentMPCConfig(polish_samples=0)
    with pytest.raises(ValueError, match="polish_rate"):
        LatentMPCConfig(polish_rate=0.0)
    with pytest.raises(ValueError, match="polish_std"):
        LatentMPCConfig(polish_std=-0.01)


def test_latent_mpc_keeps_its_plan_when_the_polish_is_worse_or_not_allowed(monkeypatch):
    """A polished plan that latent-mpc's own scoring finds worse is dropped; with ``members``
    or ``verify`` set the polish does not run."""
    import planners.gradient_search as gradient_search
    from planners.latent_mpc import LatentMPCConfig, LatentMPCPolicy

    env = gym.make("dlo_env/DLOEndpoint-v0", success_threshold=0.005)
    task = load_suite("linear-3", "train", limit=1)[0]
    start, goal = task.start.astype(np.float64), task.goal.astype(np.float64)
    weak = dict(samples=8, elites=2, iterations=1, stop_fraction=0.5)
    _, searched = LatentMPCPolicy.for_env(env, LatentMPCConfig(**weak, polish_steps=0)).plan(
        start, goal)
    calls = []

    def still(dynamics, shape, goal, starts, **kw):  # every end held where it is
        calls.append(len(starts))
        return np.zeros_like(starts[0]), 0.0, len(starts)

    monkeypatch.setattr(gradient_search, "descend", still)
    policy = LatentMPCPolicy.for_env(env, LatentMPCConfig(**weak, polish_steps=5))
    plan, error = policy.plan(start, goal)
    assert calls == [8] and error == searched and np.abs(plan).sum() > 0
    for other in (dict(members=1), dict(verify=2)):
        LatentMPCPolicy.for_env(env, LatentMPCConfig(**weak, polish_steps=5, **other)).plan(
            start, goal)
    assert calls == [8]
