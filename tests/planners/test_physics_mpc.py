"""physics-mpc starting its simulations from what it observes."""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import dlo_env  # noqa: F401  (registers the environments)
from dlo_env.shapes import segment_lengths
from planners.physics_mpc import PhysicsMPCConfig, PhysicsMPCPolicy, unstretched


def _taut_cord() -> np.ndarray:
    """A bent cord of the default length whose middle joints a pull has opened by 15 %."""
    rest = 1.0 / 19
    steps = np.full(19, rest)
    steps[8:11] *= 1.15
    headings = np.linspace(0.0, 1.2, 19)
    points = np.concatenate([[[0.0, 0.0]], np.cumsum(
        steps[:, None] * np.stack([np.cos(headings), np.sin(headings)], axis=-1), axis=0)])
    return points - points.mean(axis=0)


def test_a_taut_cord_is_simulated_at_its_rest_length_with_the_same_directions():
    taut = _taut_cord()
    cord = unstretched(taut)
    assert np.allclose(segment_lengths(cord), 1.0 / 19)
    assert np.allclose(cord.mean(axis=0), taut.mean(axis=0))
    before, after = np.diff(taut, axis=0), np.diff(cord, axis=0)
    assert np.allclose(np.arctan2(before[:, 1], before[:, 0]), np.arctan2(after[:, 1], after[:, 0]))
    at_rest = cord.copy()  # an even cord comes back unchanged
    assert np.array_equal(unstretched(at_rest), at_rest)


def test_a_rebuilt_cord_stays_on_the_table_and_a_degenerate_one_is_left_alone():
    taut = _taut_cord()
    taut += 0.995 - taut.max(axis=0)  # touching the rim's corner
    assert (np.abs(unstretched(taut)) <= 1.0).all()
    degenerate = np.zeros((20, 2))
    assert np.array_equal(unstretched(degenerate), degenerate)


def test_physics_mpc_plans_from_a_cord_held_taut_round_a_peg():
    """Regression: both grippers can pull the cord taut round a peg, a shape no reset builds
    ("shape must be a cord of length ...")."""
    taut = _taut_cord()
    bend = taut[9] + np.array([-0.03, 0.03])  # a peg inside the bend, by the opened joints
    with gym.make("dlo_env/DLODualEndpoint-v0", max_pegs=4) as env:
        policy = PhysicsMPCPolicy.for_env(env, PhysicsMPCConfig(samples=4, elites=2,
                                                                iterations=1, moves=1))
        policy.reset()
        policy._cord.set_pegs(bend[None])
        plan, error = policy.plan(taut, np.roll(taut, 1, axis=1))
        assert plan.shape == (1, 2, 2) and np.isfinite(error)
