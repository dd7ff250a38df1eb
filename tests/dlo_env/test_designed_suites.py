"""Designed suites: random starts and drawn curves the cord rests in, scored direction-free."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import dlo_env  # noqa: F401
from dlo_env.designed_suites import (
    DESIGNED_SUITES,
    designed_suite_seeds,
    designed_task,
    load_designed_suite,
)
from dlo_env.shapes import direction_free_error, is_cord_like, on_table
from dlo_env.tasks import suite_seeds


@pytest.mark.parametrize("grasp", ["head", "both"])
def test_designed_tasks_are_reproducible_on_the_table_and_far_from_their_start(grasp):
    tasks = load_designed_suite("shapes-curves", "test", grasp=grasp, limit=6)
    again = load_designed_suite("shapes-curves", "test", grasp=grasp, limit=6)
    for a, b in zip(tasks, again):
        assert np.array_equal(a.goal, b.goal) and np.array_equal(a.start, b.start)
        assert a.family in DESIGNED_SUITES["shapes-curves"][grasp]
        assert on_table(a.goal) and is_cord_like(a.goal)
        assert direction_free_error(a.start, a.goal) > 0.02
        if grasp == "both":
            assert np.linalg.norm(a.goal[-1] - a.goal[0]) < 0.9
    assert len({t.family for t in tasks}) > 1


def test_splits_do_not_share_seeds_with_each_other_or_the_linear_suites():
    train = set(designed_suite_seeds("shapes-curves", "train").tolist())
    test = set(designed_suite_seeds("shapes-curves", "test").tolist())
    linear = set(suite_seeds("linear-10", "test").tolist()) | set(
        suite_seeds("linear-10", "train").tolist())
    assert len(train) == 200 and len(test) == 50 and not (train & test) and not (train & linear)


def test_evaluate_scores_a_designed_suite_direction_free():
    from dlo_bench.evaluation import evaluate
    from planners import StraightLinePolicy

    result = evaluate(StraightLinePolicy(), "dlo_env/DLOEndpoint-v0", suite="shapes-curves",
                      episodes=1, fidelity=False)
    (record,) = result.records
    assert record.steps <= 200 and record.task_seed == -1
    assert record.rest_direction_free_error <= record.rest_error


@pytest.mark.parametrize(("call", "match"), [
    (lambda: designed_task("shapes-letters", 1), "suite must be one of"),
    (lambda: designed_task("shapes-curves", 1, grasp="tail"), "grasp must be one of"),
    (lambda: designed_suite_seeds("shapes-curves", "dev"), "split must be one of"),
])
def test_bad_arguments_are_one_line_errors(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_a_designed_goal_is_a_reset_option():
    (task,) = load_designed_suite("shapes-curves", "train", grasp="head", limit=1)
    env = gym.make("dlo_env/DLOEndpoint-v0", success_metric="direction_free_error")
    obs, _ = env.reset(options=task.options())
    assert np.allclose(obs["desired_goal"], task.goal.reshape(-1))
