"""Cord suites: linear tasks on held-out cords (dlo_env.cord_suites)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import dlo_env  # noqa: F401  (registers the environments)
from dlo_env.cord_suites import CORD_SUITES, cord_task, load_cord_suite, train_cord
from dlo_env.randomize import DEFAULT_RANGES, TEST_CORDS, near_test_cords
from dlo_env.shapes import error
from dlo_env.tasks import load_suite, suite_seeds


def test_test_tasks_run_on_the_test_cords_in_turn_with_the_linear_seeds():
    tasks = load_cord_suite("cords-2", "test", limit=8)
    assert [t.cord for t in tasks] == [0, 1, 2, 3, 4, 5, 0, 1]
    for t in tasks:
        cord = TEST_CORDS[t.cord]
        assert {k: getattr(t.params, k) for k in cord} == cord
        assert t.task.difficulty == 2
    assert [t.task.seed for t in tasks] == suite_seeds("linear-2", "test")[:8].tolist()
    # the start is made on the task's own cord: its length is the cord's
    for t in tasks:
        length = np.linalg.norm(np.diff(t.task.start, axis=0), axis=1).sum()
        assert length == pytest.approx(t.params.length, rel=0.02)


def test_the_same_seed_on_another_cord_gives_another_task():
    plain = load_suite("linear-1", "test", limit=3)
    cords = load_cord_suite("cords-1", "test", limit=3)
    assert plain[0].seed == cords[0].task.seed
    assert error(plain[1].goal, cords[1].task.goal) > 0.005  # a cord three times as heavy


def test_train_cords_are_drawn_in_the_ranges_away_from_the_test_cords():
    rows = []
    for seed in range(40):
        p = train_cord(seed)
        rows.append([getattr(p, k) for k in DEFAULT_RANGES])
        for k, (lo, hi) in DEFAULT_RANGES.items():
            assert lo <= getattr(p, k) <= hi
    assert not near_test_cords(np.array(rows), tuple(DEFAULT_RANGES)).any()
    assert train_cord(3) == train_cord(3)
    assert len({tuple(r) for r in rows}) == 40


def test_an_episode_runs_on_the_task_cord_and_the_reference_actions_reach_the_goal():
    t = cord_task("cords-1", "test", 2)
    with gym.make("dlo_env/DLOEndpoint-v0", success_threshold=1e-6) as env:
        obs, info = env.reset(options=t.options())
        assert info["params"] == t.params
        np.testing.assert_array_equal(obs["desired_goal"], t.task.goal.reshape(-1))
        for action in t.task.reference_actions:
            obs, _, terminated, truncated, info = env.step(action)
            assert not truncated
        assert info["error"] < 1e-6


@pytest.mark.parametrize("args, match", [
    (("cords-9", "test", 0), "suite must be one of"),
    (("cords-1", "val", 0), "split must be one of"),
    (("cords-1", "test", 50), "index must be an int in 0..49"),
])
def test_bad_arguments_get_one_line_errors(args, match):
    with pytest.raises(ValueError, match=match):
        cord_task(*args)


def test_the_suites_are_the_first_difficulties():
    assert CORD_SUITES == {"cords-1": 1, "cords-2": 2, "cords-3": 3}
