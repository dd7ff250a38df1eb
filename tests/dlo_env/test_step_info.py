"""The at-rest trial's copy of the cord, and the step ``info`` whose errors are computed on read."""

from __future__ import annotations

import copy
import pickle

import gymnasium as gym
import numpy as np
import pytest

import dlo_env  # noqa: F401
from dlo_env.envs import goal_env
from dlo_env.envs.goal_api import METRIC_KEYS, goal_metrics
from dlo_env.envs.step_info import StepInfo
from dlo_env.tasks import at_rest, wait_for_rest

ENDPOINT = "dlo_env/DLOEndpoint-v0"
DUAL = "dlo_env/DLODualEndpoint-v0"


def _rested(cord):
    taken = wait_for_rest(cord)
    return taken, cord.shape, at_rest(cord)


def _contacts(cord):
    found = []
    for body in cord.segments:
        body.each_arbiter(found.append)
    return len(found)


# Seed 2 with pegs: the cord touches a peg at every step checked.
@pytest.mark.parametrize("env_id, pegs, seed", [(ENDPOINT, 0, 0), (DUAL, 0, 0), (ENDPOINT, 4, 2)])
def test_the_trial_copy_comes_to_rest_bitwise_as_a_deepcopy_does(env_id, pegs, seed):
    env = gym.make(env_id, max_pegs=pegs, judge_at_rest=False)
    base = env.unwrapped
    rng = np.random.default_rng(0)
    checked = contacts = 0
    _, info = env.reset(seed=seed, options={"difficulty": 1})
    # The reference moves end at the goal, then random steps: cords in motion, in contact
    # with pegs or not.
    actions = list(info["reference_actions"])[-3:] + list(
        rng.uniform(-1, 1, (3, *env.action_space.shape)).astype(np.float32))
    for a in actions:
        env.step(a)
        contacts += _contacts(base.cord) > 0
        taken, shape, rest = _rested(goal_env._copy(base.cord))
        want_taken, want_shape, want_rest = _rested(copy.deepcopy(base.cord))
        assert (taken, rest) == (want_taken, want_rest)
        assert np.array_equal(shape, want_shape)
        checked += taken > 0
    assert checked >= 3  # cords that took zero actions to come to rest
    assert contacts == (len(actions) if pegs else 0)


def test_the_trial_leaves_the_episode_unchanged():
    a, b = gym.make(ENDPOINT), gym.make(ENDPOINT)
    _, info = a.reset(seed=1, options={"difficulty": 1})
    b.reset(seed=1, options={"difficulty": 1})
    for action in info["reference_actions"]:
        wait_for_rest(goal_env._copy(a.unwrapped.cord))
        obs_a, *_ = a.step(action)
        obs_b, *_ = b.step(action)
        assert np.array_equal(obs_a["achieved_goal"], obs_b["achieved_goal"])


def test_step_info_holds_the_errors_of_the_returned_shape_in_order():
    env = gym.make(DUAL)
    obs, info = env.reset(seed=2)
    obs, _, _, _, info = env.step(env.action_space.sample())
    metrics = goal_metrics(obs["achieved_goal"].reshape(-1, 2), obs["desired_goal"].reshape(-1, 2))
    assert isinstance(info, dict) and tuple(metrics) == METRIC_KEYS
    assert list(info) == ["is_success", "at_rest", *METRIC_KEYS, "settle_actions", "params"]
    assert all(info[k] == metrics[k] for k in METRIC_KEYS)
    plain = {**info}
    assert type(plain) is dict and plain == info and list(plain) == list(info)
    for made in (copy.deepcopy(info), pickle.loads(pickle.dumps(info)), info.copy()):
        assert type(made) is dict and made == plain and list(made) == list(plain)


def test_a_step_computes_the_errors_only_when_they_are_read(monkeypatch):
    calls = []

    def counted(shapes, goals):
        calls.append(1)
        return goal_metrics(shapes, goals)

    monkeypatch.setattr(goal_env, "goal_metrics", counted)
    env = gym.make(ENDPOINT)
    env.reset(seed=0)
    for _ in range(2):  # Gymnasium's passive checker reads the first infos whole
        env.step(env.action_space.sample())
    calls.clear()
    for _ in range(3):
        *_, info = env.step(env.action_space.sample())
        assert "error" in info and isinstance(info["is_success"], bool)
        info["episode"] = {}  # as a Monitor adds it
    assert calls == []
    assert info.get("bead_share") is not None and calls == [1]
    assert info["error"] >= 0 and len(info) == 9 and calls == [1]


def test_step_info_keeps_a_value_written_over_an_error():
    info = StepInfo({"is_success": False}, lambda: dict.fromkeys(METRIC_KEYS, 1.0))
    info["error"] = 5.0
    assert info["error"] == 5.0 and info["max_error"] == 1.0
    assert list(info) == ["is_success", *METRIC_KEYS]
