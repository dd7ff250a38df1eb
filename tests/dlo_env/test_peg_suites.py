"""The suites with pegs: pegs-K (goals made around pegs) and route-K (goals that need routing)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from dlo_bench.agents import build_agent
from dlo_bench.evaluation import evaluate
from dlo_env.cord import peg_clearance
from dlo_env.peg_suites import (
    ROUTE_CONTACT,
    ROUTE_STRAIGHT_MISS,
    ROUTE_SUITES,
    find_route_seeds,
    load_peg_suite,
    load_route_suite,
    needs_routing,
    peg_suite_seeds,
    route_seeds,
    straight_miss,
)
from dlo_env.shapes import segment_lengths
from dlo_env.tasks import GOAL_STRETCH, SPLIT_SIZES, suite_seeds


def test_peg_suite_tasks_have_their_pegs_and_replay_to_their_goals():
    tasks = load_peg_suite("pegs-2", "test", limit=3)
    assert [len(t.pegs) for t in tasks] == [1, 2, 3]
    env = gym.make("dlo_env/DLOEndpoint-v0", max_pegs=4, judge_at_rest=False)
    for task in tasks:
        assert task.difficulty == 2
        obs, info = env.reset(options=task.options())
        np.testing.assert_array_equal(np.asarray(info["pegs"]), task.pegs)
        for action in task.reference_actions:
            obs, *_ = env.step(action)
        np.testing.assert_array_equal(obs["achieved_goal"], task.goal.reshape(-1))
    linear = {int(s) for k in (1, 2, 3) for split in SPLIT_SIZES
              for s in suite_seeds(f"linear-{k}", split)}
    ours = {int(s) for k in (1, 2, 3) for split in SPLIT_SIZES
            for s in peg_suite_seeds(f"pegs-{k}", split)}
    assert not linear & ours and len(ours) == 3 * sum(SPLIT_SIZES.values())
    with pytest.raises(ValueError, match="suite must be one of"):
        load_peg_suite("pegs-9")


def test_a_goal_held_taut_round_a_peg_is_redrawn_so_every_goal_is_one_the_cord_rests_in():
    # Task 8 of pegs-1's dual test split: both grippers once pulled its goal cord round its peg
    # with a segment 11 % over rest length; now its goal is redrawn.
    task = load_peg_suite("pegs-1", "test", grasp="both", limit=9)[8]
    rest = 1.0 / 19
    assert np.abs(segment_lengths(task.goal) / rest - 1.0).max() <= GOAL_STRETCH
    env = gym.make("dlo_env/DLODualEndpoint-v0", max_pegs=4, judge_at_rest=False)
    env.reset(options=task.options())
    for action in task.reference_actions:
        obs, *_ = env.step(action)
    np.testing.assert_array_equal(obs["achieved_goal"], task.goal.reshape(-1))


@pytest.mark.parametrize("grasp", ["head", "both"])
def test_the_shipped_route_seeds_are_the_ones_found_and_every_task_needs_routing(grasp):
    for suite in ROUTE_SUITES:
        shipped = route_seeds(suite, "test", grasp)
        assert len(shipped) == SPLIT_SIZES["test"]
        assert len(route_seeds(suite, "train", grasp)) == SPLIT_SIZES["train"]
        assert find_route_seeds(suite, "test", grasp, count=3) == shipped[:3]
    for task in load_route_suite("route-2", "test", grasp=grasp, limit=4):
        assert needs_routing(task)
        assert peg_clearance(task.goal, task.pegs, task.peg_radius) <= ROUTE_CONTACT
        assert straight_miss(task) > ROUTE_STRAIGHT_MISS


def test_a_straight_move_fails_route_tasks_in_the_environment():
    env_id = "dlo_env/DLOEndpoint-v0"
    with gym.make(env_id, max_pegs=4) as env:
        result = evaluate(build_agent("straight-line", env), env_id, suite="route-2", episodes=4,
                          fidelity=False)
    assert result.summary["success_rate"] == 0.0
    assert min(r.rest_error for r in result.records) > ROUTE_STRAIGHT_MISS / 2
