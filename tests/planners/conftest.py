"""Shared by the planner tests: one torch thread, and running an agent on suite tasks."""

from __future__ import annotations

from collections.abc import Callable

import gymnasium as gym
import pytest

import dlo_env  # noqa: F401  (registers the environments)
from dlo_bench import build_agent
from dlo_env.tasks import load_suite


@pytest.fixture(autouse=True)
def _one_thread(one_torch_thread):
    # Every test here runs torch on one thread (the shared fixture in tests/conftest.py).
    yield


@pytest.fixture
def solved() -> Callable[[str, str, int], int]:
    """``solved(agent, suite, limit)``: train tasks of ``suite`` the agent solves closed loop
    in ``DLOEndpoint-v0`` (its registry defaults, the shipped models)."""

    def run(agent: str, suite: str, limit: int) -> int:
        env = gym.make("dlo_env/DLOEndpoint-v0")
        policy = build_agent(agent, env)
        count = 0
        for task in load_suite(suite, "train", limit=limit):
            obs, info = env.reset(options={"start": task.start, "goal": task.goal})
            policy.reset()
            for _ in range(100):
                action, _ = policy.predict(obs)
                obs, _, terminated, truncated, info = env.step(action)
                if terminated or truncated:
                    break
            count += bool(info["is_success"])
        return count

    return run


@pytest.fixture(scope="module")
def models():
    """The shipped shape model and transition model, on the CPU."""
    from latent_model import ShapeModel, TransitionModel

    return (ShapeModel.load_or_pretrained(None, device="cpu"),
            TransitionModel.load_or_pretrained(device="cpu"))
