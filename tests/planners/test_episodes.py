"""Every planner policy notices a new episode by itself and plans per environment of a batch."""

from __future__ import annotations

from collections.abc import Callable

import gymnasium as gym
import numpy as np
import pytest

import dlo_env  # noqa: F401  (registers the environments)
from dlo_env.cord import Cord, CordParams
from dlo_env.shapes import error
from dlo_env.tasks import GRASP_ENDS, apply_action, load_suite, random_start
from planners import (
    LatentMPCConfig,
    LatentMPCPolicy,
    PhysicsMPCConfig,
    PhysicsMPCPolicy,
    PlannerPolicy,
    StraightLinePolicy,
)
from planners.episodic_policy import JUMP_ERROR, EpisodicPolicy, gripper_reach
from planners.latent_tree import LatentTreePlanner, TreeConfig
from tests.toy_models import ToyHeadModel

ENDPOINT = "dlo_env/DLOEndpoint-v0"
DUAL = "dlo_env/DLODualEndpoint-v0"


def _latent_mpc(env: gym.Env) -> LatentMPCPolicy:
    from latent_model import TransitionModel

    model = TransitionModel.load_or_pretrained(device="cpu")
    return LatentMPCPolicy.for_env(env, LatentMPCConfig(samples=32, elites=4, iterations=1),
                                   model=model)


def _tree(closed: bool) -> Callable[[gym.Env], PlannerPolicy]:
    def build(env: gym.Env) -> PlannerPolicy:
        model = ToyHeadModel()
        planner = LatentTreePlanner(model, TreeConfig(max_nodes=200), seed=0)
        return PlannerPolicy(model, planner, replan_every=5 if closed else None)

    return build


#: name -> (builder, environment id), small budgets: what matters is the state they keep.
POLICIES: dict[str, tuple[Callable[[gym.Env], object], str]] = {
    "straight-line": (lambda env: StraightLinePolicy(grasp=env.unwrapped.cord.grasp), ENDPOINT),
    "straight-line-dual": (lambda env: StraightLinePolicy(grasp="both"), DUAL),
    "latent-tree": (_tree(closed=False), ENDPOINT),
    "latent-tree-closed": (_tree(closed=True), ENDPOINT),
    "physics-mpc": (lambda env: PhysicsMPCPolicy.for_env(
        env, PhysicsMPCConfig(samples=4, elites=2, iterations=1, replan_every=4)), ENDPOINT),
    "latent-mpc-dual": (_latent_mpc, DUAL),
}


def _episodes(policy, env: gym.Env, tasks, steps: int, tell_starts: bool) -> list[np.ndarray]:
    """The actions of a plain loop over ``tasks``, each cut after ``steps`` steps (so that a
    policy that kept the last episode's plan would act on it)."""
    out = []
    for task in tasks:
        obs, _ = env.reset(options={"task": task})
        actions = []
        for t in range(steps):
            start = np.array([t == 0]) if tell_starts else None
            action, _ = policy.predict(obs, episode_start=start, deterministic=True)
            actions.append(action)
            obs, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                break
        out.append(np.stack(actions))
    return out


@pytest.mark.parametrize("name", list(POLICIES))
def test_a_plain_loop_without_episode_start_acts_as_one_that_passes_it(name):
    build, env_id = POLICIES[name]
    env = gym.make(env_id)
    grasp = env.unwrapped.cord.grasp
    tasks = load_suite("linear-2", "test", grasp=grasp, limit=3)
    told = _episodes(build(env), env, tasks, 12, tell_starts=True)
    plain = _episodes(build(env), env, tasks, 12, tell_starts=False)
    for a, b in zip(told, plain):
        np.testing.assert_array_equal(a, b)


def test_a_new_start_with_the_same_goal_is_a_new_episode():
    env = gym.make(ENDPOINT)
    a, b = load_suite("linear-1", "test", limit=2)
    policy = StraightLinePolicy()
    obs, _ = env.reset(options={"start": a.start, "goal": a.goal})
    for _ in range(3):
        obs, *_ = env.step(policy.predict(obs)[0])
    obs, _ = env.reset(options={"start": b.start, "goal": a.goal})  # same goal, cord reset
    fresh = StraightLinePolicy().predict(obs)[0]
    np.testing.assert_array_equal(policy.predict(obs)[0], fresh)


class CountingPolicy(EpisodicPolicy):
    """Holds still and counts its resets."""

    max_step = 0.02

    def __init__(self) -> None:
        self.resets = 0

    def reset(self) -> None:
        self.resets += 1

    def _act(self, obs):
        return np.zeros(2, dtype=np.float32)


def _obs(shape: np.ndarray, goal: np.ndarray, gripper: np.ndarray | None) -> dict:
    obs = {"achieved_goal": shape.reshape(-1), "desired_goal": goal.reshape(-1)}
    if gripper is not None:
        obs["observation"] = np.concatenate([shape.reshape(-1), gripper])
    return obs


def test_a_new_goal_or_a_gripper_moved_farther_than_one_action_resets_the_policy():
    a, b = load_suite("linear-1", "test", limit=2)
    policy = CountingPolicy()
    policy.predict(_obs(a.start, a.goal, a.start[0]))
    policy.predict(_obs(a.start, a.goal, a.start[0]))
    assert policy.resets == 0  # the first observation and one that goes on: no reset
    reach = gripper_reach(policy.max_step)
    step = a.start[0] + np.float32(0.9 * reach / np.sqrt(2.0))  # within reach
    policy.predict(_obs(a.start, a.goal, step))
    assert policy.resets == 0
    policy.predict(_obs(a.start, b.goal, step))
    assert policy.resets == 1  # the goal changed
    policy.predict(_obs(a.start, b.goal, step + np.float32(reach)))
    assert policy.resets == 2  # the gripper jumped: the cord was reset to the same goal


def test_without_grippers_a_jump_of_the_cord_resets_the_policy():
    a, b = load_suite("linear-1", "test", limit=2)
    policy = CountingPolicy()
    policy.predict(_obs(a.start, a.goal, None))
    policy.predict(_obs(a.start + np.float32(0.01), a.goal, None))
    assert policy.resets == 0
    policy.predict(_obs(b.start, a.goal, None))
    assert policy.resets == 1
    policy.predict(_obs(b.start, a.goal, None), episode_start=np.array([True]))
    assert policy.resets == 2  # SB3's signal is always obeyed


def test_a_vector_envs_batch_gets_one_plan_per_environment():
    envs = gym.make_vec(ENDPOINT, num_envs=2, vectorization_mode="sync")
    singles = [gym.make(ENDPOINT) for _ in range(2)]
    batch_policy = StraightLinePolicy()
    single_policies = [StraightLinePolicy() for _ in range(2)]
    obs, _ = envs.reset(seed=[3, 4], options={"difficulty": 2})
    single_obs = [env.reset(seed=s, options={"difficulty": 2})[0]
                  for env, s in zip(singles, (3, 4))]
    for _ in range(8):
        actions, _ = batch_policy.predict(obs)
        assert actions.shape == (2, 2) and actions.dtype == np.float32
        expected = [p.predict(o)[0] for p, o in zip(single_policies, single_obs)]
        np.testing.assert_array_equal(actions, np.stack(expected))
        obs, *_ = envs.step(actions)
        single_obs = [env.step(a)[0] for env, a in zip(singles, expected)]
    assert len(batch_policy.env_policies) == 2


def test_a_batch_of_one_keeps_its_leading_axis():
    env = gym.make(ENDPOINT)
    obs, _ = env.reset(seed=0)
    batched = {key: value[None] for key, value in obs.items()}
    action, _ = StraightLinePolicy().predict(batched, episode_start=np.array([True]))
    assert action.shape == (1, 2)


def test_episode_start_must_give_one_flag_per_environment():
    envs = gym.make_vec(ENDPOINT, num_envs=3, vectorization_mode="sync")
    obs, _ = envs.reset(seed=0)
    with pytest.raises(ValueError, match="episode_start must hold one flag per environment"):
        StraightLinePolicy().predict(obs, episode_start=np.array([True, False]))


def test_sb3_evaluate_policy_runs_a_planner_on_a_vector_env():
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.evaluation import evaluate_policy

    venv = make_vec_env(ENDPOINT, n_envs=2, seed=0, env_kwargs={"max_episode_steps": 60})
    successes: list[bool] = []

    def record(local_vars, _globals):
        if local_vars["done"]:
            successes.append(bool(local_vars["info"]["is_success"]))

    evaluate_policy(StraightLinePolicy(), venv, n_eval_episodes=6, deterministic=True,
                    callback=record, warn=False)
    # Random tasks of the default difficulty 1: one straight head move solves each.
    assert len(successes) >= 6 and all(successes)


@pytest.mark.parametrize(("grasp", "max_step", "rim_margin"), [
    ("head", 0.02, 0.02), ("both", 0.02, 0.02), ("head", 0.01, 0.05), ("both", 0.01, 0.05)])
def test_no_step_moves_a_gripper_beyond_gripper_reach_or_the_cord_beyond_jump_error(
        grasp, max_step, rim_margin):
    """Random full-speed actions from random starts (to the rim and, both ends held, to the
    largest span), and a first step from a gripper outside the rim's margin."""
    params = CordParams(rim_margin=rim_margin)
    reach = gripper_reach(max_step, params)
    rng = np.random.default_rng(0)
    cord = Cord(params, grasp=grasp)
    ends = GRASP_ENDS[grasp]
    worst, worst_error = 0.0, 0.0
    corner = np.stack([np.linspace(0.995, 0.995 - 0.5, 20), np.linspace(0.995, 0.995 - 0.8, 20)],
                      axis=1)
    corner = corner[0] + (corner - corner[0]) / np.linalg.norm(corner[-1] - corner[0])
    starts = [corner.astype(np.float32)] + [random_start(seed, grasp, params=params)
                                            for seed in range(6)]
    for start in starts:
        cord.reset(start)
        for _ in range(60):
            before, shape = cord.gripper_positions(), cord.shape
            apply_action(cord, np.sign(rng.uniform(-1, 1, 2 * len(ends))), max_step)
            after = cord.gripper_positions()
            worst = max(worst, *(float(np.linalg.norm(after[e] - before[e])) for e in ends))
            worst_error = max(worst_error, float(error(cord.shape, shape)))
    assert worst <= reach
    assert worst > np.sqrt(2) * max_step  # the bound is needed: one action's own length is not
    if max_step == 0.02:
        assert worst_error < JUMP_ERROR


def _count_resets(policy) -> list[int]:
    calls: list[int] = []
    original = policy.reset

    def counting() -> None:
        calls.append(1)
        original()

    policy.reset = counting
    return calls


@pytest.mark.parametrize("name", list(POLICIES))
def test_whole_plain_loop_episodes_reset_the_policy_once_each_and_never_in_between(name):
    build, env_id = POLICIES[name]
    env = gym.make(env_id, max_episode_steps=80)
    tasks = load_suite("linear-2", "test", grasp=env.unwrapped.cord.grasp, limit=3)
    policy = build(env)
    resets = _count_resets(policy)
    for task in tasks:
        obs, _ = env.reset(options={"task": task})
        while True:
            obs, _, terminated, truncated, _ = env.step(policy.predict(obs)[0])
            if terminated or truncated:
                break
    assert len(resets) == len(tasks) - 1  # the first episode starts with a fresh policy


@pytest.mark.parametrize("name", list(POLICIES))
def test_every_policy_plans_a_batch_as_independent_policies_would(name):
    build, env_id = POLICIES[name]
    envs = gym.make_vec(env_id, num_envs=2, vectorization_mode="sync")
    singles = [gym.make(env_id) for _ in range(2)]
    batch_policy = build(singles[0])
    single_policies = [build(env) for env in singles]
    obs, _ = envs.reset(seed=[3, 4], options={"difficulty": 2})
    single_obs = [env.reset(seed=s, options={"difficulty": 2})[0]
                  for env, s in zip(singles, (3, 4))]
    for _ in range(10):
        actions, _ = batch_policy.predict(obs)
        expected = [p.predict(o)[0] for p, o in zip(single_policies, single_obs)]
        np.testing.assert_array_equal(actions, np.stack(expected))
        obs, *_ = envs.step(actions)
        single_obs = [env.step(a)[0] for env, a in zip(singles, expected)]


def test_env_policies_is_empty_before_a_batch():
    assert StraightLinePolicy().env_policies == []


def test_the_sb3_loop_example_solves_the_same_tasks_in_every_loop():
    from scripts import load_script

    example = load_script("examples/sb3_loop.py")
    env = gym.make(ENDPOINT)
    tasks = load_suite("linear-1", "test", limit=3)
    told = example.plain_loop(StraightLinePolicy(), env, tasks, tell_starts=True)
    plain = example.plain_loop(StraightLinePolicy(), env, tasks, tell_starts=False)
    vector = example.vector_loop("straight-line", ENDPOINT, tasks)
    assert told == plain == vector == [True, True, True]  # one straight move solves linear-1
    assert example.vector_loop("straight-line", ENDPOINT, tasks[:1]) == [True]  # 1 task, 1 env


@pytest.mark.slow
def test_a_policy_of_one_environment_serves_a_vector_env_through_per_env_policy():
    from dlo_bench.agents import build_agent
    from planners import PerEnvPolicy

    envs = gym.vector.SyncVectorEnv([lambda: gym.make(ENDPOINT)] * 2)
    obs, _ = envs.reset(seed=0, options={"difficulty": 1})
    single = build_agent("physics-mpc-true-cord", envs.envs[0])
    assert single.plans_batches is False and StraightLinePolicy.plans_batches is True
    with pytest.raises(ValueError, match="PerEnvPolicy"):
        single.predict(obs)
    policy = PerEnvPolicy([build_agent("physics-mpc-true-cord", e) for e in envs.envs])
    actions, _ = policy.predict(obs)
    assert actions.shape == (2, 2) and envs.action_space.contains(actions)
    with pytest.raises(ValueError, match="one row per policy"):
        PerEnvPolicy([single]).predict(obs)
    envs.close()


@pytest.mark.parametrize("env_id", [ENDPOINT, DUAL])
def test_a_direction_free_policy_aims_at_the_nearer_order_of_the_goal(env_id):
    # A difficulty-1 goal given tail first: the straight line built for a direction-free
    # environment moves the held end(s) to where the goal in the nearer order has them.
    from dlo_bench.agents import build_agent

    task = load_suite("linear-1", "test", grasp="both" if env_id == DUAL else "head", limit=1)[0]
    options = {"start": task.start, "goal": task.goal[::-1].copy()}
    results = {}
    for metric in ("error", "direction_free_error"):
        env = gym.make(env_id, success_metric=metric, success_threshold=0.02)
        policy = build_agent("straight-line", env)
        assert policy.success_metric == metric
        obs, _ = env.reset(options=options)
        for _ in range(60):
            obs, _, terminated, truncated, info = env.step(policy.predict(obs)[0])
            if terminated or truncated:
                break
        results[metric] = info["direction_free_error"]
    assert results["direction_free_error"] < 0.02 < results["error"]


def test_reset_forgets_the_goal_order_chosen_for_the_episode():
    policy = StraightLinePolicy(max_step=0.02)
    policy.success_metric = "direction_free_error"
    task = load_suite("linear-1", "test", limit=1)[0]
    env = gym.make(ENDPOINT, success_metric="direction_free_error")
    obs, _ = env.reset(options={"start": task.start, "goal": task.goal[::-1].copy()})
    policy.predict(obs)
    assert policy._reversed_goal is True
    policy.reset()
    assert policy._reversed_goal is None

