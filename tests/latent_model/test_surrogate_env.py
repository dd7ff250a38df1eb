"""The surrogate environments and the differentiable step they share."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import torch

import dlo_env  # noqa: F401  (registers the environments)
from dlo_env.envs.goal_api import goal_metrics
from dlo_env.shapes import is_cord_like, on_table, random_cord_shapes, segment_lengths
from dlo_env.tasks import load_suite, split_move
from latent_model import TransitionModel
from latent_model.cord_dynamics import CordDynamics, inextensible
from latent_model.inextensible import make_inextensible
from latent_model.surrogate_env import goal_metrics_torch

IDS = {"head": "dlo_env/DLOEndpointSurrogate-v0", "both": "dlo_env/DLODualEndpointSurrogate-v0"}
REAL = {"head": "dlo_env/DLOEndpoint-v0", "both": "dlo_env/DLODualEndpoint-v0"}


@pytest.fixture(scope="module")
def model():
    tm = TransitionModel.load_pretrained(device="cpu")
    tm.requires_grad_(False)
    return tm


def _starts(count, grasp, seed=0):
    shapes = random_cord_shapes(np.random.default_rng(seed), 4 * count)
    if grasp == "both":
        shapes = shapes[np.linalg.norm(shapes[:, -1] - shapes[:, 0], axis=-1) < 0.85]
    return shapes[:count]


def make_vec(grasp, num_envs, **kwargs):
    return gym.make_vec(IDS[grasp], num_envs=num_envs, vectorization_mode="vector_entry_point",
                        device="cpu", **kwargs)


# ------------------------------------------------------------------ the step function
@pytest.mark.parametrize("grasp", ["head", "tail", "both"])
def test_one_move_of_cord_dynamics_is_what_predict_says(model, grasp):
    rng = np.random.default_rng(1)
    shapes = _starts(64, grasp)
    width = 4 if grasp == "both" else 2
    clipped = 0
    for size in (0.02, 0.3, 0.6):
        d = rng.uniform(-size, size, (len(shapes), width)).astype(np.float32)
        want = model.predict(shapes, grasp, d)
        dyn = CordDynamics(model, grasp)
        got = dyn.step(torch.from_numpy(shapes), torch.from_numpy(d))
        # Moves the grippers' rule clips too (the table; with both ends held the span, which
        # clips a move on its way, so both walk it in max_step actions).
        sent = model.reachable_moves(shapes, grasp, d)
        np.testing.assert_allclose(dyn.reachable(torch.from_numpy(shapes),
                                                 torch.from_numpy(d)).numpy(), sent, atol=1e-5)
        held = sent.reshape(len(d), -1)[:, :width] if grasp != "tail" else sent[:, 1]
        clipped += int((np.abs(held - d).max(axis=1) > 1e-3).sum())
        assert np.abs(got.numpy() - want).max() < 2e-4
    assert clipped >= 10


def test_gradients_reach_the_actions_and_match_finite_differences(model):
    tasks = load_suite("linear-2", "test", limit=3)
    start = torch.from_numpy(np.stack([t.start for t in tasks]))
    goal = torch.from_numpy(np.stack([t.goal for t in tasks]))
    dyn = CordDynamics(model, "head")

    def loss(d):
        x = start
        for j in range(d.shape[1]):
            x = dyn.step(x, d[:, j])
        return (x - goal).norm(dim=-1).mean()

    d = torch.full((3, 2, 2), 0.01)
    grad = torch.func.grad(loss)(d)
    assert grad.abs().sum() > 0
    eps = 1e-3
    bump = torch.zeros_like(d)
    bump[0, 0, 0] = eps
    numeric = (loss(d + bump) - loss(d - bump)) / (2 * eps)
    assert abs(float(numeric) - float(grad[0, 0, 0])) < 0.1 * abs(float(grad[0, 0, 0])) + 1e-3
    d.requires_grad_(True)
    loss(d).backward()
    assert torch.allclose(d.grad, grad, atol=1e-5)


def test_torch_inextensible_projection_is_the_numpy_one():
    rng = np.random.default_rng(0)
    points = (np.linspace(0, 1, 20)[None, :, None] * np.array([1.0, 0.3])
              + rng.normal(0, 0.01, (8, 20, 2))).astype(np.float32)
    for pins in ((True, False), (True, True)):
        want = make_inextensible(points, 1 / 19, np.full(8, pins[0]), np.full(8, pins[1]))
        got = inextensible(torch.from_numpy(points), 1 / 19, *pins).numpy()
        assert np.abs(got - want).max() < 1e-5


def test_metrics_in_torch_are_the_numpy_ones():
    rng = np.random.default_rng(0)
    shapes = random_cord_shapes(rng, 32)
    goals = shapes + rng.normal(0, 0.01, shapes.shape).astype(np.float32)
    want = goal_metrics(shapes, goals)
    got = goal_metrics_torch(torch.from_numpy(shapes), torch.from_numpy(goals))
    for key, value in got.items():
        assert np.allclose(value.numpy(), want[key], atol=1e-6), key


def test_batched_shape_sampler_draws_cords_on_the_table():
    shapes = random_cord_shapes(np.random.default_rng(0), 500)
    assert shapes.shape == (500, 20, 2) and shapes.dtype == np.float32
    assert is_cord_like(shapes).all() and on_table(shapes, 0.9 + 1e-6).all()
    assert np.allclose(segment_lengths(shapes), 1 / 19, atol=1e-5)
    again = random_cord_shapes(np.random.default_rng(0), 500)
    assert np.array_equal(shapes, again)


# ------------------------------------------------------------------ the environments
@pytest.mark.parametrize("grasp", ["head", "both"])
def test_surrogate_has_the_real_environments_spaces_and_info_keys(grasp):
    sur, real = gym.make(IDS[grasp], device="cpu"), gym.make(REAL[grasp])
    assert sur.observation_space == real.observation_space
    assert sur.action_space == real.action_space
    obs_s, info_s = sur.reset(seed=0)
    obs_r, info_r = real.reset(seed=0)
    assert set(info_s) == set(info_r)
    step_s = sur.step(sur.action_space.sample())[-1]
    step_r = real.step(real.action_space.sample())[-1]
    assert set(step_s) == set(step_r)
    assert step_s["at_rest"] is True and step_s["settle_actions"] == 0


@pytest.mark.parametrize("grasp", ["head", "both"])
def test_a_suite_task_loads_as_it_is_and_its_reference_actions_nearly_solve_it(grasp):
    env = gym.make(IDS[grasp], device="cpu")
    errors = []
    for task in load_suite("linear-1", "test", grasp=grasp, limit=5):
        obs, info = env.reset(options={"task": task})
        assert np.array_equal(obs["achieved_goal"], task.start.reshape(-1))
        assert np.array_equal(obs["desired_goal"], task.goal.reshape(-1))
        for action in info["reference_actions"]:
            obs, reward, terminated, truncated, info = env.step(action)
        errors.append(info["error"])
    assert np.median(errors) < 0.01


def test_a_given_task_keeps_its_seed_and_reference_actions_and_is_checked():
    task = load_suite("linear-2", "test", limit=1)[0]
    env = gym.make(IDS["head"], device="cpu")
    _, info = env.reset(options={"task": task})
    assert info["task"] is task and info["task_seed"] == task.seed
    assert np.array_equal(np.asarray(info["reference_actions"]), task.reference_actions)
    venv = make_vec("head", 2)
    _, info = venv.reset(options={"task": [task, task]})
    assert list(info["task_seed"]) == [task.seed] * 2
    stretched = type(task)(start=task.start * 1.3, goal=task.goal, difficulty=task.difficulty,
                           reference_actions=task.reference_actions, seed=task.seed,
                           grasp="head", moves=task.moves)
    with pytest.raises(ValueError, match="options\\['task'\\].start"):
        env.reset(options={"task": stretched})


def test_a_displacement_of_the_wrong_width_is_refused(model):
    with pytest.raises(ValueError, match="displacement must have shape"):
        CordDynamics(model, "both").step(torch.zeros(3, 20, 2), torch.zeros(3, 2))


def test_projection_gradients_are_finite_on_a_cord_already_at_rest_length():
    points = torch.zeros(2, 5, 2)
    points[..., 0] = torch.arange(5) * 0.25
    points.requires_grad_(True)
    inextensible(points, 0.25, True, False, 3).sum().backward()
    assert torch.isfinite(points.grad).all()


def test_changing_the_difficulty_draws_new_tasks_at_the_next_autoreset():
    venv = make_vec("head", 2, max_episode_steps=1)
    venv.reset(seed=0)
    venv.unwrapped.difficulty = 4
    zero = np.zeros((2, 2), np.float32)
    venv.step(zero)
    info = venv.step(zero)[-1]
    assert list(info["difficulty"]) == [4, 4]


def test_drawn_tasks_replay_their_moves_through_the_model(model):
    env = gym.make(IDS["head"], device="cpu", difficulty=2)
    obs, info = env.reset(seed=3)
    assert info["difficulty"] == 2 and len(info["moves"]) == 2 and info["task_seed"] == -1
    actions = np.concatenate([split_move(m, 0.02) for m in info["moves"]])
    assert np.array_equal(actions, np.asarray(info["reference_actions"]))
    shape = obs["achieved_goal"].reshape(20, 2)
    for move in info["moves"]:
        shape = model.predict(shape, "head", move)
    assert np.abs(shape - obs["desired_goal"].reshape(20, 2)).max() < 1e-4


def test_equal_actions_are_one_straight_move_and_a_zero_action_ends_it(model):
    env = gym.make(IDS["head"], device="cpu", success_threshold=1e-6).unwrapped
    obs, _ = env.reset(seed=1)
    start = obs["achieved_goal"].reshape(20, 2)
    action = np.array([0.6, -0.8], np.float32)
    for _ in range(4):
        obs = env.step(action)[0]
    whole = model.predict(start, "head", 4 * 0.02 * action)
    assert np.abs(obs["achieved_goal"].reshape(20, 2) - whole).max() < 1e-4
    rest = env.step(np.zeros(2, np.float32))[0]["achieved_goal"]
    assert np.array_equal(rest, obs["achieved_goal"])
    after = env.step(action)[0]["achieved_goal"].reshape(20, 2)  # a new move from here
    assert np.abs(after - model.predict(rest.reshape(20, 2), "head", 0.02 * action)).max() < 1e-4
    separate = gym.make(IDS["head"], device="cpu", merge_runs=False).unwrapped
    separate.reset(options={"start": start, "goal": start[::-1].copy()})
    shape = start
    for _ in range(2):
        got = separate.step(action)[0]["achieved_goal"]
        shape = model.predict(shape, "head", 0.02 * action)
    assert np.abs(got.reshape(20, 2) - shape).max() < 1e-4


def test_vector_env_steps_the_batch_like_the_single_env():
    venv = make_vec("head", 4, success_threshold=1e-6)  # no episode ends
    env = gym.make(IDS["head"], device="cpu", success_threshold=1e-6).unwrapped
    obs, _ = venv.reset(seed=0)
    actions = np.random.default_rng(0).uniform(-1, 1, (5, 4, 2)).astype(np.float32)
    for i in (0, 3):
        env.reset(options={"start": obs["achieved_goal"][i], "goal": obs["desired_goal"][i]})
        for a in actions[:, i]:
            single = env.step(a)[0]
        assert np.allclose(single["achieved_goal"], _rollout(venv, actions, seed=0)[i], atol=1e-5)


def _rollout(venv, actions, seed):
    obs, _ = venv.reset(seed=seed)
    for a in actions:
        obs = venv.step(a)[0]
    return obs["achieved_goal"]


@pytest.mark.parametrize("grasp", ["head", "both"])
def test_vector_env_is_deterministic_for_a_seed(grasp):
    actions = np.random.default_rng(0).uniform(-1, 1, (30, 8, 4 if grasp == "both" else 2))
    first = _rollout(make_vec(grasp, 8, max_episode_steps=10), actions, seed=5)
    again = _rollout(make_vec(grasp, 8, max_episode_steps=10), actions, seed=5)
    other = _rollout(make_vec(grasp, 8, max_episode_steps=10), actions, seed=6)
    assert np.array_equal(first, again) and not np.array_equal(first, other)


def test_next_step_autoreset_starts_a_new_episode_after_the_last_step():
    venv = make_vec("head", 3, max_episode_steps=2)
    obs, _ = venv.reset(seed=0)
    zero = np.zeros((3, 2), np.float32)
    venv.step(zero)
    _, _, terminated, truncated, _ = venv.step(zero)
    assert truncated.all() and not terminated.any()
    obs, reward, terminated, truncated, info = venv.step(zero)
    assert (reward == 0).all() and not (terminated | truncated).any()
    assert info["_reference_actions"].all() and (info["difficulty"] == 1).all()
    assert not np.array_equal(obs["desired_goal"][0], obs["desired_goal"][1])


def test_same_step_autoreset_reports_the_final_observation():
    venv = make_vec("head", 2, max_episode_steps=1, autoreset_mode="same_step")
    assert venv.metadata["autoreset_mode"] == gym.vector.AutoresetMode.SAME_STEP
    obs, _ = venv.reset(seed=0)
    new, _, _, truncated, info = venv.step(np.full((2, 2), 0.5, np.float32))
    assert truncated.all() and info["_final_obs"].all()
    final = info["final_obs"][0]["achieved_goal"]
    assert not np.array_equal(final, obs["achieved_goal"][0])  # the cord moved
    assert not np.array_equal(new["desired_goal"][0], obs["desired_goal"][0])  # a new task


def test_reset_mask_restarts_only_the_masked_environments():
    venv = make_vec("head", 3)
    obs, _ = venv.reset(seed=0)
    again, info = venv.reset(options={"reset_mask": np.array([False, True, False])})
    assert np.array_equal(again["desired_goal"][0], obs["desired_goal"][0])
    assert not np.array_equal(again["desired_goal"][1], obs["desired_goal"][1])
    assert list(info["_difficulty"]) == [False, True, False]


def test_uncertainty_penalty_lowers_the_reward_by_the_spread():
    plain, penalised = make_vec("head", 4), make_vec("head", 4, uncertainty_penalty=10.0)
    plain.reset(seed=0)
    penalised.reset(seed=0)
    a = np.full((4, 2), 1.0, np.float32)
    r0 = plain.step(a)[1]
    _, r1, _, _, info = penalised.step(a)
    assert (info["model_spread"] > 0).all()
    assert np.allclose(r1, r0 - 10.0 * info["model_spread"], atol=1e-6)


@pytest.mark.parametrize("kwargs, match", [
    ({"max_pegs": 2}, "max_pegs must be 0"),
    ({"uncertainty_penalty": -1.0}, "uncertainty_penalty"),
    ({"autoreset_mode": "sometimes"}, "autoreset_mode"),
    ({"reward_type": "shaped"}, "reward_type"),
])
def test_bad_constructor_arguments_are_named(kwargs, match):
    with pytest.raises(ValueError, match=match):
        make_vec("head", 2, **kwargs)


def test_bad_options_and_actions_are_named():
    venv = make_vec("head", 2)
    with pytest.raises(RuntimeError, match="needs reset"):
        venv.unwrapped.step(np.zeros((2, 2)))
    venv.reset(seed=0)
    with pytest.raises(ValueError, match="action must have shape"):
        venv.step(np.zeros(2))
    with pytest.raises(ValueError, match="finite"):
        venv.step(np.full((2, 2), np.nan))
    with pytest.raises(ValueError, match="pegs"):
        venv.reset(options={"pegs": np.zeros((1, 2))})
    with pytest.raises(ValueError, match="reset_mask"):
        venv.reset(options={"reset_mask": np.array([1, 0])})
    with pytest.raises(ValueError, match="unknown keys"):
        venv.reset(options={"difficult": 2})
    with pytest.raises(ValueError, match="one per environment"):
        venv.reset(options={"start": _starts(3, "head")})


@pytest.mark.parametrize("grasp", ["head", "both"])
def test_latent_mpc_acts_in_the_surrogate_as_in_pymunk(grasp):
    from dlo_bench import build_agent

    env = gym.make(IDS[grasp], device="cpu", success_threshold=0.01)
    policy = build_agent("latent-mpc", env)
    obs, info = env.reset(options={"task": load_suite("linear-1", "test", grasp=grasp)[0]})
    for _ in range(60):
        obs, _, terminated, _, info = env.step(policy.predict(obs, deterministic=True)[0])
        if terminated:
            break
    assert info["is_success"]


def test_settled_metrics_are_those_of_the_cord_at_rest_now():
    env = gym.make(IDS["head"], device="cpu").unwrapped
    with pytest.raises(RuntimeError, match="reset"):
        env.settled_metrics()
    obs, info = env.reset(seed=0)
    rest = env.settled_metrics()
    assert rest["at_rest"] and rest["error"] == info["error"]
    assert np.array_equal(rest["shape"].reshape(-1), obs["achieved_goal"])
