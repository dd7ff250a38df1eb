"""Cords that differ: per-episode cord parameters (``randomize``, ``options["params"]``)."""

from __future__ import annotations

import itertools
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gymnasium_check_env

import dlo_env  # noqa: F401
from dlo_env.cord import Cord, CordParams
from dlo_env.randomize import DEFAULT_RANGES, LOG_UNIFORM, SUPPORTED, draw_params
from dlo_env.shapes import TABLE_HALF
from dlo_env.tasks import apply_action, at_rest, random_start, wait_for_rest

ENDPOINT = "dlo_env/DLOEndpoint-v0"
DUAL = "dlo_env/DLODualEndpoint-v0"
IDS = [ENDPOINT, DUAL]


@pytest.mark.parametrize("corner", list(itertools.product(*SUPPORTED.values())))
def test_every_corner_of_the_supported_ranges_is_stable_at_full_speed(corner):
    params = CordParams(**dict(zip(SUPPORTED, corner)))
    rng = np.random.default_rng(0)
    for grasp in ("head", "both"):
        cord = Cord(params, grasp=grasp)
        cord.reset(random_start(1, grasp, params=params))
        dim = 4 if grasp == "both" else 2
        for _ in range(120):
            apply_action(cord, rng.choice([-1.0, 1.0], size=dim), 0.02)
            shape = cord.shape
            assert np.isfinite(shape).all() and np.abs(shape).max() <= TABLE_HALF
            stretch = np.linalg.norm(np.diff(shape, axis=0), axis=1) / params.segment - 1
            assert np.abs(stretch).max() < 0.04
        wait_for_rest(cord)
        assert at_rest(cord)


@pytest.mark.parametrize("env_id", IDS)
def test_a_randomised_env_draws_a_cord_per_episode_from_its_seed(env_id):
    a = gym.make(env_id, randomize=DEFAULT_RANGES)
    b = gym.make(env_id, randomize=dict(reversed(list(DEFAULT_RANGES.items()))))
    seen = []
    for seed in range(4):
        obs_a, info_a = a.reset(seed=seed)
        obs_b, info_b = b.reset(seed=seed)
        params = info_a["params"]
        # The same seed gives the same cord and task, whatever the order of the dict.
        assert params == info_b["params"]
        assert np.array_equal(obs_a["observation"], obs_b["observation"])
        for key, (low, high) in DEFAULT_RANGES.items():
            assert low <= getattr(params, key) <= high
        assert params.n_points == 20 and a.unwrapped.cord.params == params
        length = np.linalg.norm(np.diff(obs_a["achieved_goal"].reshape(-1, 2), axis=0),
                                axis=1).sum()
        assert length == pytest.approx(params.length, rel=0.02)
        _, _, _, _, info = a.step(a.action_space.sample())
        assert info["params"] == params
        seen.append(params)
    assert len(set(seen)) == 4


def test_an_env_without_randomize_draws_exactly_as_before():
    plain, empty = gym.make(ENDPOINT), gym.make(ENDPOINT, randomize={})
    for seed in range(3):
        obs_p, info_p = plain.reset(seed=seed)
        obs_e, info_e = empty.reset(seed=seed)
        assert np.array_equal(obs_p["desired_goal"], obs_e["desired_goal"])
        assert info_p["params"] == CordParams() == info_e["params"]


def test_log_uniform_parameters_spread_over_their_decades():
    rng = np.random.default_rng(0)
    draws = [draw_params(CordParams(), {"bending_stiffness": (0.003, 0.03)}, rng)
             for _ in range(2000)]
    below = np.mean([p.bending_stiffness < 0.003 * np.sqrt(10) for p in draws])
    assert "bending_stiffness" in LOG_UNIFORM and 0.45 < below < 0.55


def test_options_params_sets_one_episode_and_the_next_returns_to_the_default():
    env = gym.make(DUAL)
    soft = CordParams(bending_stiffness=0.003, length=0.8)
    _, info = env.reset(seed=0, options={"params": soft, "difficulty": 2})
    assert info["params"] == soft and info["task"].difficulty == 2
    _, info = env.reset(seed=0)
    assert info["params"] == CordParams()


@pytest.mark.parametrize(("randomize", "match"), [
    ([("mass", (0.1, 0.2))], "randomize must be a dict"),
    ({"n_points": (10, 20)}, "randomize keys must be some of"),
    ({"mass": 0.1}, r"randomize\['mass'\] must be a pair"),
    ({"mass": (0.3, 0.1)}, r"low <= high"),
    ({"mass": (0.1, float("nan"))}, r"finite numbers"),
    ({"bending_stiffness": (0.0001, 0.01)}, r"must lie within 0.001..0.03"),
])
def test_bad_ranges_are_one_line_errors(randomize, match):
    with pytest.raises(ValueError, match=match):
        gym.make(ENDPOINT, randomize=randomize)


@pytest.mark.parametrize(("params", "match"), [
    ({"length": 1.0}, "must be a dlo_env.CordParams"),
    (CordParams(n_points=12), "must keep the environment's n_points=20"),
])
def test_bad_episode_params_are_one_line_errors(params, match):
    env = gym.make(ENDPOINT)
    with pytest.raises(ValueError, match=match):
        env.reset(options={"params": params})


@pytest.mark.parametrize("env_id", IDS)
def test_gymnasium_check_env_passes_on_a_randomised_env(env_id):
    env = gym.make(env_id, randomize=DEFAULT_RANGES).unwrapped
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        gymnasium_check_env(env, skip_render_check=True)
    assert [str(w.message) for w in caught] == []


def test_a_refused_reset_leaves_the_environment_as_it_was():
    from dlo_env.tasks import make_task

    env = gym.make(ENDPOINT)
    obs, _ = env.reset(seed=0)
    with pytest.raises(ValueError, match=r"options\['task'\].start"):
        env.reset(options={"task": make_task(0, 1), "params": CordParams(length=0.8)})
    assert env.unwrapped.cord.params == CordParams()
    _, _, _, _, info = env.step(np.zeros(2, dtype=np.float32))  # the episode goes on
    assert info["params"] == CordParams()


def test_a_given_task_keeps_its_length_when_lengths_are_drawn():
    from dlo_env.tasks import make_task

    env = gym.make(ENDPOINT, randomize={"length": (0.7, 1.3), "friction": (0.2, 0.6)})
    _, info = env.reset(seed=0, options={"task": make_task(0, 1)})
    assert info["params"].length == pytest.approx(1.0, abs=1e-6)
    assert 0.2 <= info["params"].friction <= 0.6


def test_the_test_cords_lie_inside_the_ranges_and_only_they_are_near_themselves():
    from dlo_env.randomize import DEFAULT_RANGES, TEST_CORDS, near_test_cords

    columns = tuple(DEFAULT_RANGES)
    rows = np.array([[cord[k] for k in columns] for cord in TEST_CORDS])
    for cord in TEST_CORDS:
        assert all(DEFAULT_RANGES[k][0] <= v <= DEFAULT_RANGES[k][1] for k, v in cord.items())
    assert near_test_cords(rows, columns).all()
    assert near_test_cords(rows * 1.15, columns).all()  # within the margin
    assert not near_test_cords(rows * 1.3, columns).any()
    default = CordParams()
    assert not near_test_cords(np.array([[getattr(default, k) for k in columns]]), columns)[0]


def test_transitions_of_the_test_cords_only(tmp_path):
    from dlo_env.dataset.transitions import (
        PARAM_COLUMNS,
        TransitionCollectConfig,
        collect_transition_chunk,
    )
    from dlo_env.randomize import TEST_CORDS

    data = collect_transition_chunk(TransitionCollectConfig(seed=2, test_cords=True), 0, 40)
    test = {tuple(np.float32(cord[k]) for k in PARAM_COLUMNS) for cord in TEST_CORDS}
    seen = {tuple(row) for row in data.params}
    assert seen <= test and len(seen) >= 2
    with pytest.raises(ValueError, match="test_cords and randomize"):
        TransitionCollectConfig(test_cords=True, randomize={"mass": (0.1, 0.2)})
