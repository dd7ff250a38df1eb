from __future__ import annotations

import numpy as np
import pytest

from planners import interpolate


def test_interpolation_endpoints_equal_the_inverted_start_and_goal(toy_model):
    start, goal = toy_model.decode(np.array([[-0.5, 0.2], [0.6, -0.4]]))
    start = start + 0.003  # not exactly representable: the ends are the decoded inversions
    path, latents = interpolate(toy_model, start, goal, steps=7, return_latents=True)
    z, _, _ = toy_model.invert(np.stack([start, goal]))
    assert path.shape == (7, 20, 2) and path.dtype == np.float32
    np.testing.assert_allclose(path[0], toy_model.decode(z[:1])[0], atol=1e-6)
    np.testing.assert_allclose(path[-1], toy_model.decode(z[1:])[0], atol=1e-6)
    np.testing.assert_allclose(latents[0], z[0], atol=1e-6)
    np.testing.assert_allclose(latents[-1], z[1], atol=1e-6)


def test_interpolation_takes_evenly_spaced_latents(toy_model):
    start, goal = toy_model.decode(np.array([[-0.5, 0.0], [0.5, 0.0]]))
    _, latents = interpolate(toy_model, start, goal, steps=5, return_latents=True)
    np.testing.assert_allclose(np.diff(latents[:, 0]), 0.25, atol=1e-6)


def test_interpolation_accepts_flat_shapes(toy_model):
    start, goal = toy_model.decode(np.array([[-0.5, 0.0], [0.5, 0.0]]))
    path = interpolate(toy_model, start.reshape(-1), goal.reshape(-1), steps=3)
    assert path.shape == (3, 20, 2)


def test_interpolation_rejects_a_goal_of_the_wrong_shape(toy_model):
    start = toy_model.decode(np.zeros((1, 2)))[0]
    with pytest.raises(ValueError, match=r"goal must have shape \(20, 2\)"):
        interpolate(toy_model, start, np.zeros((19, 2)), steps=3)


def test_interpolation_rejects_too_few_steps(toy_model):
    start = toy_model.decode(np.zeros((1, 2)))[0]
    with pytest.raises(ValueError, match="steps must be an int >= 2"):
        interpolate(toy_model, start, start, steps=1)
