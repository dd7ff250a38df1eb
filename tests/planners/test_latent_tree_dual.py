"""The latent trees with both ends held (``TreeConfig(grasp="both")``, DLODualEndpoint-v0): each
end moves in straight lines, both at once, and plans carry an ends axis."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from scripts import load_script

import dlo_env  # noqa: F401  (registers the environments)
from dlo_bench import AGENTS, build_agent
from dlo_bench.fidelity import transition_fidelity
from dlo_env.cord import Cord
from dlo_env.shapes import error
from dlo_env.tasks import DEFAULT_MAX_STEP, apply_action, load_suite, split_move, wait_for_rest
from planners.latent_tree import KINO_CONFIG, LatentTreePlanner, TreeConfig
from planners.moves import actions_by_move

DUAL = "dlo_env/DLODualEndpoint-v0"


def test_a_kino_plan_moves_both_ends_as_the_transition_model_predicts(models):
    shape_model, transition = models
    task = load_suite("linear-1", "train", grasp="both", limit=1)[0]
    config = TreeConfig(**{**KINO_CONFIG.__dict__, "grasp": "both"})
    plan = LatentTreePlanner(shape_model, config, transition_model=transition).plan(
        task.start, task.goal)
    assert plan.success and plan.grasp == "both"
    assert plan.waypoints.shape == (len(plan.shapes), 2, 2)
    assert plan.moves.shape == (len(plan.shapes) - 1, 2, 2)
    assert np.allclose(plan.corners[0], task.start[[0, -1]])
    for k, move in enumerate(plan.moves):
        predicted = transition.predict(plan.shapes[k], "both", move.reshape(-1),
                                       inextensible=False)
        assert np.allclose(predicted, plan.shapes[k + 1], atol=1e-5)
    cord = Cord(transition.cord_params, grasp="both")
    cord.reset(task.start)
    for move in plan.moves:
        for action in split_move(move, DEFAULT_MAX_STEP):
            apply_action(cord, action, DEFAULT_MAX_STEP)
        wait_for_rest(cord)
    assert error(cord.shape, plan.shapes[-1]) < 0.02
    fidelity = transition_fidelity(plan, task.start)
    assert np.isfinite(fidelity.errors).all() and fidelity.mean_error < 0.02


def test_a_latent_edge_keeps_each_end_on_its_straight_line(models):
    shape_model, _ = models
    task = load_suite("linear-1", "train", grasp="both", limit=2)[1]
    plan = LatentTreePlanner(shape_model, TreeConfig(grasp="both")).plan(task.start, task.goal)
    assert plan.waypoints.shape == (len(plan.shapes), 2, 2)
    for a, b in zip(plan.nodes[:-1], plan.nodes[1:]):
        for j in range(2):
            ends = plan.waypoints[a:b + 1, j].astype(np.float64)
            chord = ends[-1] - ends[0]
            if np.linalg.norm(chord) < 1e-9:
                continue
            across = np.abs((ends - ends[0]) @ np.array([-chord[1], chord[0]])) / np.linalg.norm(
                chord)
            assert across.max() < 1e-5  # on the line between its corners


def test_moves_of_both_ends_become_four_wide_actions():
    moves = actions_by_move(np.array([[0.0, 0.0], [0.5, 0.0]]),
                            np.array([[[0.1, 0.0], [0.5, 0.05]]]), 0.02)
    actions = np.stack(moves[0])
    assert actions.shape == (5, 4)
    assert np.allclose(actions.sum(axis=0) * 0.02, [0.1, 0.0, 0.0, 0.05])


@pytest.mark.parametrize("agent", ["latent-tree-kino", "latent-tree-closed"])
def test_the_tree_agents_act_in_the_dual_environment(agent):
    env = gym.make(DUAL)
    policy = build_agent(agent, env)
    task = load_suite("linear-1", "test", grasp="both", limit=1)[0]
    obs, _ = env.reset(options={"task": task})
    for _ in range(100):
        action, _ = policy.predict(obs)
        assert action.shape == (4,)
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    assert info["is_success"]


def test_the_learned_model_example_runs_the_kino_tree_with_both_ends_held_too():
    example = load_script("examples/learned_model_planners.py")
    assert "latent-tree-kino" in example.AGENTS
    for name in example.AGENTS:  # each in both of the example's environments
        assert {"dlo_env/DLOEndpoint-v0", DUAL} <= set(AGENTS[name].environments)
