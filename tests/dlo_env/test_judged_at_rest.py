"""Success is judged on the cord at rest (``judge_at_rest``, the default)."""

from __future__ import annotations

import copy

import gymnasium as gym
import numpy as np
import pytest

import dlo_env  # noqa: F401
from dlo_env.envs import DLOEndpointEnv
from dlo_env.shapes import error
from dlo_env.tasks import MAX_SETTLE_ACTIONS, REST_CHECK_MARGIN, at_rest, wait_for_rest

ENDPOINT = "dlo_env/DLOEndpoint-v0"
DUAL = "dlo_env/DLODualEndpoint-v0"


@pytest.mark.parametrize("env_id", [ENDPOINT, DUAL])
@pytest.mark.parametrize("threshold", [0.02, 0.005])
def test_success_comes_only_with_the_cord_at_rest_within_the_threshold(env_id, threshold):
    env = gym.make(env_id, success_threshold=threshold)
    successes = 0
    for seed in range(4):
        obs, info = env.reset(seed=seed, options={"difficulty": 1})
        # The reference actions, then a nudge past the goal: the cord passes near the goal.
        actions = list(info["reference_actions"]) + [env.action_space.sample() * 0.3] * 3
        for a in actions:
            obs, _, terminated, truncated, info = env.step(a)
            assert terminated == info["is_success"]
            if info["is_success"]:
                assert info["at_rest"] and info["error"] <= threshold
                assert env.unwrapped.cord.max_point_speed() < 1e-3
                assert error(obs["achieved_goal"].reshape(-1, 2),
                             obs["desired_goal"].reshape(-1, 2)) == info["error"]
                successes += 1
                break
    assert successes >= 2  # the reference actions reach the goal (at rest) in most tasks


def test_a_solved_step_lets_the_cord_come_to_rest_as_zero_actions_would():
    env = gym.make(ENDPOINT)
    twin = gym.make(ENDPOINT, judge_at_rest=False)
    obs, info = env.reset(seed=3, options={"difficulty": 1})
    twin.reset(seed=3, options={"difficulty": 1})
    moves = [a for a in info["reference_actions"] if np.any(a)]
    for a in moves:
        obs, _, terminated, _, info = env.step(a)
        twin.step(a)
        if terminated:
            break
    assert terminated and info["settle_actions"] >= 1
    zero = np.zeros(2, dtype=np.float32)
    for _ in range(info["settle_actions"]):
        twin_obs, *_ = twin.step(zero)
    # The same physics: the solved step is the move followed by zero actions, bitwise.
    assert np.array_equal(twin_obs["achieved_goal"], obs["achieved_goal"])


def test_a_moving_cord_within_the_threshold_that_rests_outside_it_is_not_solved():
    env = gym.make(ENDPOINT, success_threshold=0.02)
    env.reset(seed=0)
    base = env.unwrapped
    rng = np.random.default_rng(0)
    checked = 0
    for _ in range(60):
        base.step(rng.uniform(-1, 1, 2).astype(np.float32))
        moving = base.cord.shape
        rest = copy.deepcopy(base.cord)
        wait_for_rest(rest, base.max_step)
        # A goal the moving cord is within the threshold of, but the cord at rest is not:
        # the moving shape pushed away from where the cord comes to rest.
        gap = error(moving, rest.shape)
        if gap < 1e-4:
            continue
        goal = moving + (moving - rest.shape) * (0.0199 / gap)
        base.goal, base._goal_flat = goal, goal.reshape(-1).astype(np.float32)
        if error(moving, goal) > 0.02 or error(rest.shape, goal) <= 0.02:
            continue
        shape, speed = base.cord.shape_and_speed()
        distance = error(shape, base._goal_flat.reshape(-1, 2))
        assert base._settle_if_solved(shape, speed, distance) == 0
        _, info = base._observe(shape, speed, distance)
        assert not info["is_success"] and not info["at_rest"] and info["error"] <= 0.02
        checked += 1
    assert checked >= 5


@pytest.mark.parametrize("env_id", [ENDPOINT, DUAL])
def test_the_cord_moves_less_than_the_check_margin_while_coming_to_rest(env_id):
    env = gym.make(env_id)
    base = env.unwrapped
    rng = np.random.default_rng(1)
    worst = 0.0
    for seed in range(3):
        env.reset(seed=seed)
        for _ in range(25):
            base.step(rng.uniform(-1, 1, env.action_space.shape).astype(np.float32))
            rest = copy.deepcopy(base.cord)
            taken = wait_for_rest(rest, base.max_step)
            assert taken < MAX_SETTLE_ACTIONS and at_rest(rest)
            worst = max(worst, error(base.cord.shape, rest.shape))
    assert worst < REST_CHECK_MARGIN


def test_settled_metrics_leave_the_episode_unchanged():
    a, b = gym.make(ENDPOINT), gym.make(ENDPOINT)
    a.reset(seed=7)
    b.reset(seed=7)
    rng = np.random.default_rng(2)
    for _ in range(15):
        action = rng.uniform(-1, 1, 2).astype(np.float32)
        obs_a, *_ = a.step(action)
        metrics = a.unwrapped.settled_metrics()
        obs_b, *_ = b.step(action)
        assert np.array_equal(obs_a["achieved_goal"], obs_b["achieved_goal"])
        assert metrics["at_rest"] and set(metrics) >= {"error", "max_error",
                                                       "direction_free_error", "bead_share"}


def test_zero_actions_bring_the_cord_to_rest():
    env = gym.make(ENDPOINT)
    env.reset(seed=4)
    env.step(np.ones(2, dtype=np.float32))
    _, _, _, _, info = env.step(np.ones(2, dtype=np.float32))
    assert not info["at_rest"]
    for _ in range(MAX_SETTLE_ACTIONS):
        _, _, _, _, info = env.step(np.zeros(2, dtype=np.float32))
        if info["at_rest"]:
            break
    assert info["at_rest"]
    assert info["error"] == pytest.approx(env.unwrapped.settled_metrics()["error"], abs=1e-9)


@pytest.mark.parametrize("bad", [1, "yes", None])
def test_judge_at_rest_must_be_a_bool(bad):
    with pytest.raises(ValueError, match="judge_at_rest must be True or False"):
        gym.make(ENDPOINT, judge_at_rest=bad)


def test_settled_metrics_before_reset_is_one_line():
    env = DLOEndpointEnv()
    with pytest.raises(RuntimeError, match="call reset"):
        env.settled_metrics()


def test_straight_moves_cut_off_during_a_move_is_not_solved():
    # The goal is the cord part-way through a move; the time limit stops the episode there,
    # before the move ends: the cord still moves, so the macro step is not solved.
    from dlo_env.straight_moves import StraightMoves
    from dlo_env.tasks import make_task

    task = make_task(3, 1)
    probe = gym.make(ENDPOINT, judge_at_rest=False)
    probe.reset(options={"task": task})
    for a in task.reference_actions[:3]:
        obs, *_ = probe.unwrapped.step(a)
    env = StraightMoves(gym.make(ENDPOINT, max_episode_steps=3))
    env.reset(options={"start": task.start, "goal": obs["achieved_goal"]})
    _, _, terminated, truncated, info = env.step(task.moves[0].astype(np.float32))
    assert truncated and not info["at_rest"] and not terminated


def test_straight_moves_judge_the_cord_at_rest_after_the_move():
    from dlo_env.straight_moves import StraightMoves
    from dlo_env.tasks import make_task

    task = make_task(4, 1)
    env = StraightMoves(gym.make(ENDPOINT))
    env.reset(options={"task": task})
    _, _, terminated, truncated, info = env.step(task.moves[0].astype(np.float32))
    assert terminated and not truncated and info["at_rest"] and info["error"] <= 0.02


def test_a_direction_free_env_solves_a_goal_given_in_reverse():
    from dlo_env.tasks import make_task

    task = make_task(5, 1)
    reverse = task.goal[::-1].copy()
    for metric, solved in (("direction_free_error", True), ("error", False)):
        env = gym.make(ENDPOINT, success_metric=metric)
        env.reset(options={"start": task.start, "goal": reverse})
        for a in task.reference_actions:
            obs, reward, terminated, _, info = env.step(a)
            if terminated:
                break
        assert terminated == solved
        if solved:
            assert info["direction_free_error"] <= 0.02 < info["error"]
            assert reward == pytest.approx(-info["direction_free_error"])
            assert env.unwrapped.compute_reward(obs["achieved_goal"], obs["desired_goal"],
                                                None) == reward


def test_success_metric_must_be_known():
    with pytest.raises(ValueError, match="success_metric must be one of"):
        gym.make(ENDPOINT, success_metric="chamfer")
