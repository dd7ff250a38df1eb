from __future__ import annotations

import numpy as np
import pytest

from dlo_env.shapes import error
from planners import LatentTreePlanner, Plan, TreeConfig

# The toy head follows a parabola along u: a direct latent line from u=-0.9 to u=0.9 bends the
# head's path by 0.24 m, so only a path of several short straight moves is allowed.
FAR = np.array([[-0.9, 0.0], [0.9, 0.0]])


def _edges(plan: Plan):
    for a, b in zip(plan.nodes[:-1], plan.nodes[1:]):
        yield int(a), int(b)


def _deviation_from_chord(points: np.ndarray) -> float:
    chord = points[-1] - points[0]
    unit = chord / np.linalg.norm(chord)
    rel = points - points[0]
    return float(np.abs(rel[:, 0] * unit[1] - rel[:, 1] * unit[0]).max())


def test_tree_planner_on_a_toy_latent_finds_a_path_that_respects_its_constraints(toy_model):
    start, goal = toy_model.decode(FAR)
    planner = LatentTreePlanner(toy_model, seed=0, straightness=0.005, similarity=0.02)
    plan = planner.plan(start, goal)
    cfg = planner.config

    assert plan.success
    assert len(plan.nodes) > 2, "the direct line bends the head; the path must have corners"
    assert plan.shapes.shape == (len(plan.latents), 20, 2)
    assert plan.nodes[0] == 0 and plan.nodes[-1] == len(plan.shapes) - 1
    # Consecutive decoded shapes are similar.
    steps = np.asarray(error(plan.shapes[1:], plan.shapes[:-1]))
    assert steps.max() <= cfg.similarity + 1e-6
    # On every edge, the decoded head moves along a straight line (within the tolerance,
    # which grows with the length of the move).
    for a, b in _edges(plan):
        head = plan.shapes[a : b + 1, 0].astype(np.float64)
        tolerance = cfg.straightness + cfg.straightness_ratio * np.linalg.norm(head[-1] - head[0])
        assert _deviation_from_chord(head) <= tolerance + 1e-6
    # The waypoints lie exactly on the straight moves between the corners.
    for a, b in _edges(plan):
        assert _deviation_from_chord(plan.waypoints[a : b + 1].astype(np.float64)) < 1e-5
    # It reaches the goal: the last latent decodes to the goal, the last corner is its head.
    assert error(plan.shapes[-1], goal) <= cfg.goal_threshold
    np.testing.assert_allclose(plan.corners[0], start[0], atol=1e-6)
    np.testing.assert_allclose(plan.corners[-1], goal[0], atol=1e-6)


def test_a_direct_line_that_keeps_the_head_straight_is_planned_as_one_move(toy_model):
    start, goal = toy_model.decode(np.array([[0.0, -0.5], [0.0, 0.5]]))  # u fixed: head on a line
    plan = LatentTreePlanner(toy_model, seed=0).plan(start, goal)
    assert plan.success and plan.stats["direct"]
    np.testing.assert_allclose(plan.moves, [goal[0] - start[0]], atol=1e-6)
    assert plan.stats["nodes"] == 1


def test_the_straightness_tolerance_grows_with_the_length_of_the_move(toy_model):
    start, goal = toy_model.decode(FAR)  # the direct line bends the head by 0.24 m over 0.72 m
    strict = LatentTreePlanner(toy_model, seed=0, straightness_ratio=0.0).plan(start, goal)
    lenient = LatentTreePlanner(toy_model, seed=0, straightness_ratio=0.5).plan(start, goal)
    assert not strict.stats["direct"]
    assert lenient.success and lenient.stats["direct"]


def test_candidates_are_decoded_in_batches(toy_model):
    start, goal = toy_model.decode(FAR)
    plan = LatentTreePlanner(toy_model, seed=0, straightness=0.005).plan(start, goal)
    # One model call evaluates many candidates: many more nodes than decoder calls.
    assert plan.stats["nodes"] / plan.stats["decoder_calls"] > 5
    assert plan.stats["seconds"] > 0


def test_the_same_seed_gives_the_same_plan(toy_model):
    start, goal = toy_model.decode(FAR)
    a = LatentTreePlanner(toy_model, seed=3, shortcut=False).plan(start, goal)
    b = LatentTreePlanner(toy_model, seed=3, shortcut=False).plan(start, goal)
    np.testing.assert_array_equal(a.latents, b.latents)


def test_a_spent_budget_returns_an_unsuccessful_plan_towards_the_closest_node(toy_model):
    start, goal = toy_model.decode(FAR)
    plan = LatentTreePlanner(toy_model, seed=0, max_nodes=5, straightness=0.005).plan(start, goal)
    assert not plan.success
    assert plan.stats["stop"] == "nodes"
    assert error(plan.shapes[-1], goal) < error(start, goal)


def test_plan_rejects_a_goal_of_the_wrong_shape(toy_model):
    start = toy_model.decode(np.zeros((1, 2)))[0]
    planner = LatentTreePlanner(toy_model)
    with pytest.raises(ValueError, match=r"goal must have shape \(20, 2\) or \(40,\)"):
        planner.plan(start, np.zeros((21, 2)))
    with pytest.raises(ValueError, match="goal must be finite"):
        planner.plan(start, np.full((20, 2), np.nan))


def test_unknown_or_invalid_parameters_are_rejected(toy_model):
    with pytest.raises(ValueError, match="unknown LatentTreePlanner parameters"):
        LatentTreePlanner(toy_model, step=0.1)
    with pytest.raises(ValueError, match="TreeConfig.step_length must be a number > 0"):
        TreeConfig(step_length=0.0)
    with pytest.raises(ValueError, match="TreeConfig.grasp must be one of"):
        TreeConfig(grasp="middle")
    with pytest.warns(DeprecationWarning, match="use grasp="):
        assert TreeConfig(end="tail").grasp == "tail"  # the deprecated name still works
    with pytest.raises(ValueError, match="TreeConfig.straightness_ratio must be >= 0"):
        TreeConfig(straightness_ratio=-0.1)


def test_a_model_without_the_interface_is_rejected():
    with pytest.raises(ValueError, match="model must have a decode"):
        LatentTreePlanner(object())
