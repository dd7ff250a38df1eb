"""Specification of the kinodynamic latent tree (``TreeConfig(edges="moves")``, latent-tree-kino):
edges are straight moves whose outcome the transition model predicts."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import dlo_env  # noqa: F401  (registers the environments)
from dlo_bench import build_agent
from dlo_env.cord import Cord
from dlo_env.shapes import error
from dlo_env.tasks import load_suite, wait_for_rest
from latent_model import TransitionModel, TransitionModelConfig
from planners.latent_tree import KINO_CONFIG, LatentTreePlanner, TreeConfig
from planners.policy import PlannerPolicy


def test_a_plan_is_straight_moves_whose_predicted_outcomes_the_simulator_reproduces(models):
    shape_model, transition = models
    task = load_suite("linear-1", "train", limit=1)[0]
    planner = LatentTreePlanner(shape_model, KINO_CONFIG, transition_model=transition)
    plan = planner.plan(task.start, task.goal)
    assert plan.success and plan.stats["edges"] == "moves"
    assert np.allclose(plan.shapes[0], task.start) and np.allclose(plan.corners[0],
                                                                   task.start[0])
    assert error(plan.shapes[-1], task.goal) <= KINO_CONFIG.goal_threshold
    # Every node is the model's (raw, as the tree predicts) prediction of the move from its parent.
    for k, move in enumerate(plan.moves):
        predicted = transition.predict(plan.shapes[k], "head", move, inextensible=False)
        assert np.allclose(predicted, plan.shapes[k + 1], atol=1e-5)
    # The simulator, carrying out the same moves, ends where the plan says (the model's error).
    cord = Cord(transition.cord_params, grasp="head")
    cord.reset(task.start)
    from dlo_env.tasks import DEFAULT_MAX_STEP, apply_action, split_move

    for move in plan.moves:
        for action in split_move(move, DEFAULT_MAX_STEP):
            apply_action(cord, action, DEFAULT_MAX_STEP)
        wait_for_rest(cord)
    assert error(cord.shape, plan.shapes[-1]) < 0.02


def test_moves_edges_need_a_transition_model_for_the_same_cord(models):
    shape_model, _ = models
    with pytest.raises(ValueError, match="needs a transition_model") as info:
        LatentTreePlanner(shape_model, KINO_CONFIG)
    assert "\n" not in str(info.value)
    other = TransitionModel(TransitionModelConfig(n_points=12, width=8, depth=1, members=1),
                            device="cpu")
    with pytest.raises(ValueError, match="transition_model must be for 20 points"):
        LatentTreePlanner(shape_model, KINO_CONFIG, transition_model=other)
    with pytest.raises(ValueError, match="TreeConfig.edges must be one of"):
        TreeConfig(edges="springs")
    with pytest.raises(ValueError, match="moves_per_plan must be None or an int >= 1"):
        PlannerPolicy(shape_model, moves_per_plan=0)


def test_the_agent_executes_one_move_then_plans_again_from_the_cord_at_rest():
    env = gym.make("dlo_env/DLOEndpoint-v0")
    policy = build_agent("latent-tree-kino", env)
    task = load_suite("linear-3", "train", limit=1)[0]
    obs, _ = env.reset(options={"start": task.start, "goal": task.goal})
    action, _ = policy.predict(obs, episode_start=np.array([True]))
    plan = policy.plans[0]
    first = np.linalg.norm(plan.moves[0])
    assert len(policy._queue) + 1 == max(1, int(np.ceil(first / 0.02 - 1e-9)))
    plans = 1
    for _ in range(60):
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
        action, _ = policy.predict(obs)
        plans = max(plans, policy.stats.plans)
    assert plans >= 2 or info["is_success"]
    coarse = gym.make("dlo_env/DLOEndpoint-v0", max_step=0.03)
    with pytest.raises(ValueError, match="max_step"):
        build_agent("latent-tree-kino", coarse)


@pytest.mark.slow
def test_it_solves_train_tasks_of_difficulty_two_closed_loop(solved):
    assert solved("latent-tree-kino", "linear-2", 5) >= 4


def test_a_transition_model_of_another_cord_is_refused_for_the_environment(models):
    from dataclasses import replace

    shape_model, transition = models
    slippery = TransitionModel(replace(transition.config, cord_friction=0.3, members=1,
                                       mean_network=False, mean_by_grasp=False), device="cpu")
    planner = LatentTreePlanner(shape_model, KINO_CONFIG, transition_model=slippery)
    with pytest.raises(ValueError, match=r"trained for one cord, with friction=0\.3 where the "
                       r"environment's cord has 0\.4"):
        PlannerPolicy(shape_model, planner).check_env(gym.make("dlo_env/DLOEndpoint-v0"))


def test_the_agent_plans_on_the_model_of_several_cords_told_a_designed_suites_cord(models):
    from dlo_bench.agents import model_files
    from dlo_env.designed_suites import designed_suite_cord

    letters_cord = designed_suite_cord("shapes-letters")
    letters = gym.make("dlo_env/DLOEndpoint-v0", params=letters_cord)
    planner = build_agent("latent-tree-kino", letters).planner
    assert planner.transition_model.config.cord_inputs and planner.cord == letters_cord
    assert model_files("latent-tree-kino", letters)[1].endswith("transition-letters.pt")
    assert build_agent("latent-tree-kino", gym.make("dlo_env/DLOEndpoint-v0")).planner.cord is None
    # Its edges are the model's predictions for the told cord, not for the default one.
    task = load_suite("linear-1", "train", limit=1)[0]
    moves, predicted, _ = planner._best_moves(task.start[None], task.goal[None],
                                              np.random.default_rng(0))
    model = planner.transition_model
    told = model.predict(task.start, "head", moves[0].reshape(-1), inextensible=False,
                         params=letters_cord)
    np.testing.assert_allclose(predicted[0], told, atol=1e-6)
    default = model.predict(task.start, "head", moves[0].reshape(-1), inextensible=False)
    assert not np.allclose(predicted[0], default, atol=1e-4)
    shape_model, _ = models
    with pytest.raises(ValueError, match="cord is told to a transition model of several cords"):
        LatentTreePlanner(shape_model, KINO_CONFIG, transition_model=models[1],
                          cord=letters_cord)
    with pytest.raises(ValueError, match="cord is told to a transition_model; none was given"):
        LatentTreePlanner(shape_model, cord=letters_cord)
