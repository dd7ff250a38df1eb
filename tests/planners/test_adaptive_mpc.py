"""latent-mpc-adaptive: the cord fitted to the moves of the episode (planners.adaptive_mpc)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import torch

import dlo_env  # noqa: F401  (registers the environments)
from dlo_env import CordParams
from dlo_env.shapes import random_cord_shape
from latent_model.transition_model import TransitionModel, TransitionModelConfig
from planners.adaptive_mpc import AdaptConfig, AdaptiveLatentMPCPolicy, _Move
from planners.latent_mpc import LatentMPCConfig

SMALL = LatentMPCConfig(samples=16, elites=4, iterations=1, far_moves=0)


def _model(cord_inputs: bool = True) -> TransitionModel:
    torch.manual_seed(0)
    model = TransitionModel(TransitionModelConfig(width=32, depth=2, members=1,
                                                  cord_inputs=cord_inputs), device="cpu").eval()
    with torch.no_grad():  # outputs of full size, so that the cord's inputs matter
        model.net.weights[-1].mul_(10.0)
    return model


def test_a_model_of_one_cord_is_refused():
    with pytest.raises(ValueError, match="model must be a transition model conditioned"):
        AdaptiveLatentMPCPolicy(_model(cord_inputs=False))


def test_the_fit_finds_the_cord_that_made_the_moves():
    model = _model()
    policy = AdaptiveLatentMPCPolicy(model, config=SMALL, adapt=AdaptConfig(
        ranges={"bending_stiffness": (0.003, 0.03)}, candidates=64, rounds=4))
    rng = np.random.default_rng(1)
    true = CordParams(bending_stiffness=0.022)
    moves = []
    for _ in range(3):
        start = random_cord_shape(rng).astype(np.float32)
        shift = rng.uniform(-0.1, 0.1, 2).astype(np.float32)
        end = model.predict(start, "head", shift, params=true, inextensible=False)
        moves.append(_Move(start, shift, end))
    row, err = policy.fit(moves)
    default_err = policy._errors(policy.default_row[None], moves)[0]
    assert err < 0.2 * default_err
    assert row[1] == pytest.approx(0.022, rel=0.1)
    assert row[[0, 2, 3]].tolist() == policy.default_row[[0, 2, 3]].tolist()
    assert policy.fit(moves)[0].tolist() == row.tolist()  # seeded: the same cord again


def test_an_episode_records_its_moves_refits_and_reset_forgets_them():
    model = _model()
    with gym.make("dlo_env/DLOEndpoint-v0") as env:
        policy = AdaptiveLatentMPCPolicy.for_env(env, config=SMALL,
                                                 model=model, adapt=AdaptConfig(candidates=8,
                                                                                rounds=1))
        obs, _ = env.reset(seed=3, options={"difficulty": 3,
                                            "params": CordParams(bending_stiffness=0.02)})
        for _ in range(3 * (SMALL.settle_actions + 8)):
            action, _ = policy.predict(obs, deterministic=True)
            obs, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                break
        assert len(policy.moves_seen) >= 1 and len(policy.adapt_stats.cords) >= 1
        assert policy.cord_row.tolist() == policy.adapt_stats.cords[-1]
        policy.reset()
        assert policy.moves_seen == [] and policy.cord_row.tolist() == policy.default_row.tolist()
    with pytest.raises(ValueError, match="model is required"):
        AdaptiveLatentMPCPolicy.for_env(env)


def test_the_length_is_read_off_the_observed_cord_not_fitted():
    model = _model()
    with gym.make("dlo_env/DLOEndpoint-v0") as env:
        policy = AdaptiveLatentMPCPolicy.for_env(env, config=SMALL, model=model,
                                                 adapt=AdaptConfig(candidates=8, rounds=1))
        obs, _ = env.reset(seed=3, options={"params": CordParams(length=0.85)})
        policy.predict(obs, episode_start=np.array([True]), deterministic=True)
        assert policy.cord_row[0] == pytest.approx(0.85, rel=1e-4)
        assert policy.cord_row[1:].tolist() == policy.default_row[1:].tolist()
        blind = AdaptiveLatentMPCPolicy.for_env(env, config=SMALL, model=model, adapt=AdaptConfig(
            candidates=8, rounds=1, observe_length=False))
        blind.predict(obs, episode_start=np.array([True]), deterministic=True)
        assert blind.cord_row[0] == 1.0


def test_physics_mpc_true_cord_simulates_each_episode_cord():
    from dlo_env.cord_suites import cord_task
    from planners.physics_mpc import PhysicsMPCConfig, TrueCordPhysicsMPCPolicy

    small = PhysicsMPCConfig(samples=4, elites=2, iterations=1, moves=1)
    with gym.make("dlo_env/DLOEndpoint-v0") as env, gym.make("dlo_env/DLOEndpoint-v0") as other:
        policy = TrueCordPhysicsMPCPolicy(env, small)
        policy.check_env(env)
        with pytest.raises(ValueError, match="reads the cord of the environment it was made"):
            policy.check_env(other)
        task = cord_task("cords-1", "test", 1)  # three times as heavy
        obs, _ = env.reset(options=task.options())
        policy.predict(obs, episode_start=np.array([True]), deterministic=True)
        assert policy.params == task.params and policy._cord.params == task.params
        obs, _ = env.reset(seed=0)
        policy.predict(obs, episode_start=np.array([True]), deterministic=True)
        assert policy.params == CordParams()


def test_physics_mpc_simulates_a_cord_of_another_length_at_its_observed_length():
    """A cord of another length cannot be reset onto the default cord: physics-mpc simulates
    the default cord's other parameters at the observed length (one test cord is 0.85 m)."""
    from dataclasses import replace as with_fields

    from dlo_env.cord_suites import cord_task
    from planners.physics_mpc import PhysicsMPCConfig, PhysicsMPCPolicy, TrueCordPhysicsMPCPolicy

    small = PhysicsMPCConfig(samples=4, elites=2, iterations=1, moves=1)
    task = cord_task("cords-1", "test", 2)
    assert task.params.length == 0.85
    with gym.make("dlo_env/DLOEndpoint-v0") as env:
        policy = PhysicsMPCPolicy.for_env(env, small)
        obs, _ = env.reset(options=task.options())
        policy.predict(obs, episode_start=np.array([True]), deterministic=True)
        simulated = policy._cord.params
        assert simulated.length == pytest.approx(0.85, rel=1e-4)
        assert with_fields(simulated, length=1.0) == CordParams()  # the rest: the default
        assert policy.params == CordParams()  # what it was told stays the default cord
        obs, _ = env.reset(seed=0)
        policy.predict(obs, episode_start=np.array([True]), deterministic=True)
        assert policy._cord.params == CordParams()  # the default length: exactly the default
        oracle = TrueCordPhysicsMPCPolicy(env, small)
        with pytest.raises(ValueError, match="takes a batch of 1, got 2 observations"):
            oracle.predict({k: np.stack([v, v]) for k, v in obs.items()}, deterministic=True)


def test_the_fitted_ranges_are_the_union_of_the_model_files_ranges():
    from planners.adaptive_mpc import trained_ranges

    info = {"sources": [{"collect": {"randomize": {"mass": [0.05, 0.2],
                                                   "friction": [0.2, 0.6]}}},
                        {"collect": {"randomize": {"mass": [0.1, 0.3]}}},
                        {"collect": {}}]}  # a file of the default cord
    assert trained_ranges(info) == {"mass": (0.05, 0.3), "friction": (0.2, 0.6)}
    assert trained_ranges({"data": {"randomize": {"length": [0.8, 1.2]}}}) == {
        "length": (0.8, 1.2)}
    assert trained_ranges({}) == {}
