from __future__ import annotations

import gymnasium as gym
import numpy as np

import dlo_env  # noqa: F401
from planners import StraightLinePolicy


def test_straight_line_moves_the_head_straight_to_the_goal_head_and_solves_one_move_tasks():
    env = gym.make("dlo_env/DLOEndpoint-v0")
    policy = StraightLinePolicy()
    obs, _ = env.reset(seed=1, options={"difficulty": 1})
    start_head, goal_head = obs["observation"][40:42].copy(), obs["desired_goal"][:2].copy()
    heads = [start_head]
    for _ in range(100):
        action, _ = policy.predict(obs)
        assert np.linalg.norm(action) <= 1.0 + 1e-6
        obs, _, terminated, truncated, info = env.step(action)
        heads.append(obs["observation"][40:42].copy())
        if terminated or truncated:
            break
    assert info["is_success"]
    # Every head position lies on the segment from the start head to the goal head.
    chord = goal_head - start_head
    rel = np.array(heads) - start_head
    across = np.abs(rel[:, 0] * chord[1] - rel[:, 1] * chord[0]) / np.linalg.norm(chord)
    assert across.max() < 1e-4


def test_straight_line_holds_still_once_the_goal_head_is_reached():
    env = gym.make("dlo_env/DLOEndpoint-v0")
    start = np.stack([np.linspace(-0.5, 0.5, 20), np.zeros(20)], axis=1)
    goal = start + [0.0, 0.1]  # a sideways shift one head move cannot make
    obs, _ = env.reset(options={"start": start, "goal": goal})
    policy = StraightLinePolicy()
    actions = []
    for _ in range(10):
        action, _ = policy.predict(obs)
        actions.append(action)
        obs, _, terminated, _, info = env.step(action)
    assert not terminated and not info["is_success"]
    np.testing.assert_allclose(np.sum(actions, axis=0) * 0.02, [0.0, 0.1], atol=1e-5)
    assert np.all(actions[-1] == 0.0)
    np.testing.assert_allclose(obs["observation"][40:42], goal[0], atol=2e-3)
