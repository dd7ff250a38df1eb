"""Specification of latent-mpc (planners.latent_mpc): CEM on the learned transition model."""

from __future__ import annotations

from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest

import dlo_env  # noqa: F401  (registers the environments)
from dlo_bench import build_agent
from dlo_env.cord import CordParams
from dlo_env.tasks import load_suite
from latent_model import TransitionModel, TransitionModelConfig
from planners.interfaces import PlanningPolicy
from planners.latent_mpc import LatentMPCConfig, LatentMPCPolicy

TINY = TransitionModelConfig(width=8, depth=1, members=2)


def test_it_is_a_planning_policy_registered_for_both_environments():
    for env_id, width in (("dlo_env/DLOEndpoint-v0", 2), ("dlo_env/DLODualEndpoint-v0", 4)):
        env = gym.make(env_id)
        policy = LatentMPCPolicy.for_env(env, LatentMPCConfig(samples=8, elites=2, iterations=1),
                                         model=TransitionModel(TINY, device="cpu"))
        assert isinstance(policy, PlanningPolicy)
        obs, _ = env.reset(seed=1)
        action, _ = policy.predict(obs)
        assert action.shape == (width,) and np.abs(action).max() <= 1.0
        assert policy.episode_stats().plans == 1
    assert build_agent("latent-mpc", gym.make("dlo_env/DLODualEndpoint-v0")).grasp == "both"


def test_a_model_for_another_cord_or_step_is_refused_in_one_line():
    other = TransitionModel(TransitionModelConfig(n_points=12, width=8, depth=1, members=2),
                            device="cpu")
    with pytest.raises(ValueError, match="cord of 12 points") as info:
        LatentMPCPolicy.for_env(gym.make("dlo_env/DLOEndpoint-v0"), model=other)
    assert "\n" not in str(info.value)
    coarse = gym.make("dlo_env/DLOEndpoint-v0", max_step=0.03)
    with pytest.raises(ValueError, match="max_step=0.02 m"):
        LatentMPCPolicy.for_env(coarse, model=TransitionModel(TINY, device="cpu"))
    assert CordParams().n_points == 20


@pytest.mark.slow
def test_the_shipped_model_solves_train_tasks_of_difficulty_two_closed_loop(solved):
    assert solved("latent-mpc", "linear-2", 3) == 3


def test_a_cord_held_at_the_tail_is_planned_with_tail_moves():
    # No environment holds the tail alone; the policy drives a tail-held Cord as env.step does.
    from dlo_env.cord import Cord
    from dlo_env.shapes import error
    from dlo_env.tasks import DEFAULT_MAX_STEP, apply_action, make_task

    model = TransitionModel.load_or_pretrained(device="cpu")
    policy = LatentMPCPolicy(model, grasp="tail", config=LatentMPCConfig(samples=64, elites=8,
                                                                         iterations=3))
    solved = 0
    for seed in (3, 4, 5):
        task = make_task(seed, 1, "tail")
        cord = Cord(model.cord_params, grasp="tail")
        cord.reset(task.start)
        policy.reset()
        for _ in range(60):
            obs = {"achieved_goal": cord.shape.reshape(-1), "desired_goal": task.goal.reshape(-1)}
            action, _ = policy.predict(obs)
            assert action.shape == (2,)
            apply_action(cord, action, DEFAULT_MAX_STEP)
        solved += error(cord.shape, task.goal) <= 0.02
    assert policy.grasp == "tail" and policy.ends == ("tail",)
    assert solved >= 2


def test_an_episode_plans_the_same_whatever_ran_before_it():
    model = TransitionModel(TINY, device="cpu")
    tasks = load_suite("linear-2", "train", limit=2)
    policy = LatentMPCPolicy(model, config=LatentMPCConfig(samples=16, elites=4, iterations=2))
    def first_action(task, start: bool) -> np.ndarray:
        obs = {"achieved_goal": task.start.reshape(-1), "desired_goal": task.goal.reshape(-1)}
        return policy.predict(obs, episode_start=np.array([start]))[0]

    fresh = first_action(tasks[0], True)
    first_action(tasks[1], True)  # another episode first, as evaluate runs them
    np.testing.assert_array_equal(first_action(tasks[0], True), fresh)
    policy.reset()
    np.testing.assert_array_equal(first_action(tasks[0], False), fresh)


def test_by_default_it_scores_with_one_network_the_mean_network_when_there_is_one():
    ensemble_only = TransitionModel(TINY, device="cpu")
    assert LatentMPCPolicy(ensemble_only).members == 1  # the ensemble's first network
    spread = LatentMPCConfig(spread_weight=0.1)
    assert LatentMPCPolicy(ensemble_only, config=spread).members is None  # all: a spread
    with_mean = TransitionModel(TransitionModelConfig(**{**TINY.__dict__, "mean_network": True}),
                                device="cpu")
    assert LatentMPCPolicy(with_mean).members is None  # predict's default: the mean network
    assert LatentMPCPolicy(with_mean, config=LatentMPCConfig(members=2)).members == 2


def test_a_model_trained_on_another_stiffness_is_refused_in_one_line(tmp_path):
    from dlo_env.dataset.transitions import TransitionCollectConfig, collect_transition_chunk
    from latent_model.transition_training import TransitionTrainConfig, train_transition_model

    stiff = CordParams(bending_stiffness=0.02)
    data = collect_transition_chunk(TransitionCollectConfig(seed=3, cord=stiff), 0, 20)
    model = train_transition_model(data, tmp_path, TransitionTrainConfig(
        steps=1, batch_size=8, eval_every=1, validation_fraction=0.2), TINY, device="cpu")
    with pytest.raises(ValueError, match=r"trained for one cord, with bending_stiffness=0\.02 "
                       r"where the environment's cord has 0\.01") as info:
        LatentMPCPolicy.for_env(gym.make("dlo_env/DLOEndpoint-v0"), model=model)
    assert "\n" not in str(info.value)
    env = gym.make("dlo_env/DLOEndpoint-v0", params=stiff)
    LatentMPCPolicy.for_env(env, model=model)
    several = TransitionModel(replace(TINY, cord_inputs=True), device="cpu")
    LatentMPCPolicy.for_env(env, model=several)  # a model of several cords sees the cord


def test_a_model_of_several_cords_is_told_the_environments_cord_within_its_ranges():
    from dlo_env.designed_suites import designed_suite_cord

    model = TransitionModel.load_or_pretrained(device="cpu", cords=True)
    letters = designed_suite_cord("shapes-letters")
    env = gym.make("dlo_env/DLOEndpoint-v0", params=letters)
    policy = LatentMPCPolicy.for_env(env, model=model)
    assert policy.cord == letters
    shape = env.reset(seed=0)[0]["achieved_goal"].reshape(-1, 2)
    move = np.array([[0.1, 0.0]], dtype=np.float32)
    told = policy._predict(shape[None], move)
    np.testing.assert_array_equal(told, model.predict(shape[None], "head", move, params=letters))
    assert not np.allclose(told, model.predict(shape[None], "head", move))  # default cord
    softer = gym.make("dlo_env/DLOEndpoint-v0", params=replace(letters, bending_stiffness=0.001))
    with pytest.raises(ValueError, match=r"trained on cords of other parameters than the "
                       r"environment's: bending_stiffness=0\.001 outside 0\.003\.\.0\.03"):
        LatentMPCPolicy.for_env(softer, model=model)
    with pytest.raises(ValueError, match="cord is told to a transition model of several cords"):
        LatentMPCPolicy(TransitionModel(TINY, device="cpu"), cord=letters)
    rough = LatentMPCPolicy.for_env(gym.make("dlo_env/DLOEndpoint-v0", params=letters,
                                             max_pegs=2, peg_friction=0.3), model=model)
    assert rough.cord == letters  # told what the model predicts: not the pegs' friction
    rough.predict(gym.make("dlo_env/DLOEndpoint-v0", params=letters).reset(seed=1)[0])


def test_latent_mpc_plans_on_the_model_of_several_cords_where_the_env_has_another_cord():
    from dlo_bench.agents import model_files
    from dlo_env.designed_suites import designed_suite_cord

    letters = gym.make("dlo_env/DLODualEndpoint-v0", params=designed_suite_cord("shapes-letters"))
    policy = build_agent("latent-mpc", letters)
    assert policy.model.config.cord_inputs and policy.cord == letters.unwrapped.params
    assert model_files("latent-mpc", letters)[0].endswith("transition-letters.pt")
    default = gym.make("dlo_env/DLODualEndpoint-v0")
    assert build_agent("latent-mpc", default).cord is None
    assert model_files("latent-mpc", default)[0].endswith("transition.pt")


def test_verify_executes_the_plan_whose_simulated_first_move_ends_nearest():
    from dlo_env.cord import Cord
    from dlo_env.shapes import error
    from planners.physics_mpc import simulate

    env = gym.make("dlo_env/DLOEndpoint-v0")
    obs, _ = env.reset(seed=3)
    config = LatentMPCConfig(samples=16, elites=4, iterations=2, moves=1, far_moves=0,
                             verify=3)
    policy = LatentMPCPolicy.for_env(env, config, model=TransitionModel(TINY, device="cpu"))
    assert policy.keep == 3
    offered = {}
    choose = policy._choose

    def spy(shape, goal, plans, errors):
        offered["plans"] = plans.copy()
        return choose(shape, goal, plans, errors)

    policy._choose = spy
    shape, goal = obs["achieved_goal"].reshape(-1, 2), obs["desired_goal"].reshape(-1, 2)
    plan, err = policy.plan(shape.astype(np.float64), goal.astype(np.float64))
    cord = Cord(env.unwrapped.params)
    simulated = [error(simulate(cord, shape, p, ("head",), config.verify_settle), goal)
                 for p in offered["plans"]]
    assert len(simulated) == 3
    assert err == pytest.approx(min(simulated), abs=1e-4)
    assert np.array_equal(plan, offered["plans"][int(np.argmin(simulated))])
