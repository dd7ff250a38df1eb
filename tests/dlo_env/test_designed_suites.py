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
        assert a.family in DESIGNED_SUITES["shapes-curves"].families[grasp]
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
    (lambda: designed_task("shapes-words", 1), "suite must be one of"),
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


@pytest.mark.parametrize("grasp", ["head", "both"])
def test_letters_come_in_turn_on_the_suites_cord_and_rest_near_their_drawing(grasp):
    from dataclasses import replace

    from dlo_env import goals
    from dlo_env.cord import CordParams
    from dlo_env.designed_suites import LETTERS_CORD, designed_suite_cord

    cord = replace(CordParams(), **LETTERS_CORD)
    assert designed_suite_cord("shapes-letters") == cord
    assert designed_suite_cord("shapes-curves") is None
    tasks = load_designed_suite("shapes-letters", "test", grasp=grasp, limit=11)
    assert [t.family for t in tasks] == [*goals.LETTERS, next(iter(goals.LETTERS))]
    for t in tasks[:10]:
        assert t.options()["params"] == cord and t.params == cord
        assert on_table(t.goal) and is_cord_like(t.goal)
        drawn = goals.letter(t.family, aspect=t.settings["aspect"], center=t.settings["center"],
                             angle=t.settings["angle"], grasp=grasp, params=cord, relax=False)
        assert direction_free_error(t.goal, drawn) < 0.015, t.family
    assert load_designed_suite("shapes-curves", "test", limit=1)[0].options().keys() == {
        "start", "goal"}


def test_a_letters_task_resets_the_environment_onto_its_cord():
    (task,) = load_designed_suite("shapes-letters", "test", grasp="both", limit=1)
    env = gym.make("dlo_env/DLODualEndpoint-v0", success_metric="direction_free_error")
    obs, info = env.reset(options=task.options())
    assert info["params"] == task.params
    assert np.allclose(obs["achieved_goal"], task.start.reshape(-1), atol=1e-5)
