"""The Protocols the planners share: what they need from a model, what they offer a harness."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import dlo_env  # noqa: F401  (registers the environments)
from planners import (
    EpisodeStats,
    PhysicsMPCPolicy,
    PlannerPolicy,
    PlanningPolicy,
    Policy,
    ShapeSurrogate,
    StraightLinePolicy,
)


def test_a_toy_model_with_the_four_members_is_a_shape_surrogate(toy_model):
    assert isinstance(toy_model, ShapeSurrogate)
    assert not isinstance(object(), ShapeSurrogate)


def test_planners_are_planning_policies_and_the_reference_is_a_policy(toy_model):
    assert isinstance(PlannerPolicy(toy_model), PlanningPolicy)
    assert isinstance(PhysicsMPCPolicy(), PlanningPolicy)
    assert isinstance(StraightLinePolicy(), Policy)
    assert not isinstance(StraightLinePolicy(), PlanningPolicy)


def test_episode_stats_report_the_first_and_latest_plans_and_reset_forgets_them(toy_model):
    env = gym.make("dlo_env/DLOEndpoint-v0")
    policy = PlannerPolicy(toy_model, replan_every=3)
    before = policy.episode_stats()
    assert isinstance(before, EpisodeStats) and before.plans == 0 and before.first_plan is None
    obs, _ = env.reset(seed=0, options={"difficulty": 2})
    for step in range(7):
        action, _ = policy.predict(obs, episode_start=np.array([step == 0]))
        obs, *_ = env.step(action)
    stats = policy.episode_stats()
    assert stats.plans == policy.stats.plans >= 1 and stats.seconds > 0
    assert stats.first_plan is policy.plans[0] and stats.latest_plan is policy.plans[-1]
    policy.reset()
    assert policy.episode_stats().plans == 0 and policy.episode_stats().first_plan is None


def test_the_physics_planner_refuses_an_environment_it_was_not_made_for():
    policy = PhysicsMPCPolicy(grasp="head")
    with pytest.raises(ValueError, match="for_env"):
        policy.check_env(gym.make("dlo_env/DLODualEndpoint-v0"))
