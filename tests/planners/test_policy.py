from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from toy_models import ToyHeadModel

import dlo_env  # noqa: F401
from dlo_env.cord import Cord
from dlo_env.tasks import apply_action
from planners import LatentTreePlanner, Plan, PlannerPolicy, StraightLinePolicy
from planners.moves import actions_through
from planners.policy import REST_MOTION


class HoldingPlanner(LatentTreePlanner):
    """Plans to stay where the cord is: the real cord never gets closer to the goal."""

    def plan(self, start, goal, *, goal_latent=None, seed=None):
        start = np.asarray(start, dtype=np.float32).reshape(-1, 2)
        return Plan(shapes=start[None], latents=np.zeros((1, 2), np.float32),
                    waypoints=start[:1], nodes=np.array([0]), success=True)


class RecordingPlanner(LatentTreePlanner):
    """Plans one straight head move to the goal's head, predicting the shapes by simulation.

    ``offset`` (metres) is added to the predicted shapes: a plan the real cord does not follow.
    """

    offset = 0.0

    def plan(self, start, goal, *, goal_latent=None, seed=None):
        start = np.asarray(start, dtype=np.float32).reshape(-1, 2)
        goal = np.asarray(goal, dtype=np.float32).reshape(-1, 2)
        cord = Cord(grasp="head")
        cord.reset(start)
        shapes, heads = [cord.shape], [cord.gripper_positions()["head"]]
        for action in actions_through(heads[0], goal[:1], 0.02):
            apply_action(cord, action, 0.02)
            shapes.append(cord.shape)
            heads.append(cord.gripper_positions()["head"])
        shapes = np.array(shapes) + np.float32(self.offset)
        return Plan(shapes=shapes, latents=np.zeros((len(shapes), 2), np.float32),
                    waypoints=np.array(heads, np.float32), nodes=np.array([0, len(shapes) - 1]),
                    success=True)


def _run_episode(env, policy, seed, difficulty=1):
    obs, _ = env.reset(seed=seed, options={"difficulty": difficulty})
    policy.reset()
    actions = []
    for _ in range(100):
        action, _ = policy.predict(obs)
        actions.append(np.asarray(action))
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    return np.array(actions), info


@pytest.mark.parametrize("replan_every", [None, 5])
def test_planner_policy_actions_are_within_bounds(toy_model, replan_every):
    env = gym.make("dlo_env/DLOEndpoint-v0")
    policy = PlannerPolicy(toy_model, replan_every=replan_every)
    policy.check_env(env)
    for seed in range(2):
        actions, _ = _run_episode(env, policy, seed, difficulty=2)
        assert actions.shape[1:] == (2,) and actions.dtype == np.float32
        assert np.isfinite(actions).all()
        assert (np.linalg.norm(actions, axis=1) <= 1.0 + 1e-6).all()
        assert policy.stats.plans >= 1 and len(policy.plans) == policy.stats.plans
        if replan_every is not None and len(actions) > replan_every + 1:
            assert policy.stats.plans > 1


def test_closed_loop_replans_every_k_steps(toy_model):
    env = gym.make("dlo_env/DLOEndpoint-v0")
    policy = PlannerPolicy(toy_model, replan_every=3, replan_tolerance=0.0,
                           wait_for_corner=False)
    obs, _ = env.reset(seed=0, options={"difficulty": 3})
    for _ in range(7):
        action, _ = policy.predict(obs)
        obs, *_ = env.step(action)
    assert policy.stats.plans == 3  # steps 0, 3 and 6


def test_closed_loop_checks_the_plan_only_at_the_end_of_a_straight_move(toy_model):
    env = gym.make("dlo_env/DLOEndpoint-v0")
    planner = RecordingPlanner(toy_model)
    planner.offset = 0.03  # never on track: every check replans
    policy = PlannerPolicy(toy_model, planner, replan_every=3)
    obs, _ = env.reset(seed=1, options={"difficulty": 1})
    moves = []
    for _ in range(12):
        action, _ = policy.predict(obs)
        moves.append(len(policy.plans))
        obs, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            break
    first = policy.plans[0]
    steps_of_move = len(first.shapes) - 1  # one straight move, one action per recorded shape
    assert steps_of_move > 3
    # The one plan runs to its corner (or the end of the episode) although the cord is 3 cm
    # off from step 1 on: there is no replan at steps 3, 6, ... in the middle of the move.
    executed = min(len(moves), steps_of_move)
    assert executed > 3
    assert moves[:executed] == [1] * executed


@pytest.mark.parametrize("patience, plans", [(2, 2), (None, 4)])
def test_closed_loop_holds_still_after_replans_without_progress(toy_model, patience, plans):
    env = gym.make("dlo_env/DLOEndpoint-v0")
    policy = PlannerPolicy(toy_model, HoldingPlanner(toy_model), replan_every=3,
                           patience=patience)
    obs, _ = env.reset(seed=0, options={"difficulty": 2})
    for _ in range(12):
        action, _ = policy.predict(obs)
        assert not action.any()
        obs, *_ = env.step(action)
    # Replans at steps 0, 3, 6, 9; the second and third find no progress, so with patience 2
    # the policy stops before planning at step 6.
    assert policy.stats.plans == plans
    assert policy.stats.stalled == (patience is not None)
    assert policy.stats.best_error > 0.02


@pytest.mark.parametrize("offset, kept", [(0.0, True), (0.03, False)])
def test_closed_loop_keeps_a_plan_the_cord_follows_and_replans_one_it_does_not(
    toy_model, offset, kept
):
    env = gym.make("dlo_env/DLOEndpoint-v0")
    planner = RecordingPlanner(toy_model)
    planner.offset = offset
    policy = PlannerPolicy(toy_model, planner, replan_every=3, replan_tolerance=0.01,
                           wait_for_corner=False)
    obs, _ = env.reset(seed=1, options={"difficulty": 1})
    for _ in range(7):
        action, _ = policy.predict(obs)
        obs, *_ = env.step(action)
    assert (policy.stats.kept, policy.stats.plans) == ((2, 1) if kept else (0, 3))


def test_closed_loop_lets_the_cord_come_to_rest_before_the_next_plan(toy_model):
    env = gym.make("dlo_env/DLOEndpoint-v0")
    policy = PlannerPolicy(toy_model, RecordingPlanner(toy_model), replan_every=3)
    obs, _ = env.reset(seed=0, options={"difficulty": 2})
    first_move = None
    shapes, plans, actions = [obs["achieved_goal"]], [], []
    for _ in range(30):
        action, _ = policy.predict(obs)
        if first_move is None:
            first_move = len(policy.plans[0].shapes) - 1  # actions of the one straight move
        plans.append(len(policy.plans))
        actions.append(action)
        obs, *_ = env.step(action)
        shapes.append(obs["achieved_goal"])
    second = plans.index(2)  # the step at which the second plan was made
    assert second > first_move, "the policy waited after the first plan's last action"
    assert not np.any(actions[first_move:second])
    motion = np.abs(shapes[second] - shapes[second - 1]).max()
    assert motion <= REST_MOTION or second - first_move == policy.settle_steps


def test_planning_failure_is_recorded_and_falls_back_to_the_straight_line(toy_model):
    env = gym.make("dlo_env/DLOEndpoint-v0")
    # No edge passes: every decoded step moves the cord more than the similarity bound.
    planner = LatentTreePlanner(toy_model, max_nodes=1, similarity=1e-9)
    policy = PlannerPolicy(toy_model, planner)
    obs, _ = env.reset(seed=0, options={"difficulty": 1})
    head, goal_head = obs["observation"][40:42], obs["desired_goal"][:2]
    reference = StraightLinePolicy()
    planned, _ = policy.predict(obs)
    expected, _ = reference.predict(obs)
    assert not policy.plans[0].success
    assert policy.stats.failures == 1
    np.testing.assert_allclose(planned, expected, atol=1e-6)
    direction = (goal_head - head) / np.linalg.norm(goal_head - head)
    np.testing.assert_allclose(planned / np.linalg.norm(planned), direction, atol=1e-5)


def test_episode_start_resets_the_policy(toy_model):
    env = gym.make("dlo_env/DLOEndpoint-v0")
    policy = PlannerPolicy(toy_model)
    obs, _ = env.reset(seed=0)
    policy.predict(obs)
    policy.predict(obs, episode_start=np.array([True]))
    assert policy.stats.plans == 1 and len(policy.plans) == 1


def test_batched_observations_give_batched_actions(toy_model):
    env = gym.make("dlo_env/DLOEndpoint-v0")
    obs, _ = env.reset(seed=0)
    batch = {k: v[None] for k, v in obs.items()}
    action, state = PlannerPolicy(toy_model).predict(batch, state="s")
    assert action.shape == (1, 2) and state == "s"


def test_a_model_for_another_cord_is_rejected_with_a_clear_error():
    small = ToyHeadModel(n_points=10)
    env = gym.make("dlo_env/DLOEndpoint-v0")
    policy = PlannerPolicy(small)
    with pytest.raises(ValueError, match="n_points=10 but the environment's cord has n_points=20"):
        policy.check_env(env)
    obs, _ = env.reset(seed=0)
    with pytest.raises(ValueError, match="model's cord has n_points=10"):
        policy.predict(obs)


def test_a_policy_with_another_step_size_is_rejected(toy_model):
    env = gym.make("dlo_env/DLOEndpoint-v0", max_step=0.01)
    with pytest.raises(ValueError, match="max_step"):
        PlannerPolicy(toy_model).check_env(env)


def test_invalid_policy_arguments_are_rejected(toy_model):
    with pytest.raises(ValueError, match="replan_every must be None or an int >= 1"):
        PlannerPolicy(toy_model, replan_every=0)
    with pytest.raises(ValueError, match="replan_tolerance must be >= 0"):
        PlannerPolicy(toy_model, replan_every=5, replan_tolerance=-0.01)
    with pytest.raises(ValueError, match="settle_steps must be an int >= 0"):
        PlannerPolicy(toy_model, replan_every=5, settle_steps=-1)
    with pytest.raises(ValueError, match="patience must be None or an int >= 1"):
        PlannerPolicy(toy_model, replan_every=5, patience=0)
    with pytest.raises(ValueError, match="planner must plan for the model's n_points=20"):
        PlannerPolicy(toy_model, LatentTreePlanner(ToyHeadModel(n_points=10)))
