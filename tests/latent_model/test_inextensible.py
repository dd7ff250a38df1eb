"""Specification of latent_model.inextensible (predictions moved onto rest-length segments)."""

from __future__ import annotations

import numpy as np

from dlo_env.shapes import random_cord_shape
from latent_model.inextensible import make_inextensible

REST = 1.0 / 19


def _stretched(count: int, seed: int) -> np.ndarray:
    # Cord-like shapes whose segments are 0.85-1.15 of the rest length, as a hesitant mean.
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        shape = random_cord_shape(rng, margin=0.3).astype(np.float64)
        seg = np.diff(shape, axis=0) * rng.uniform(0.85, 1.15, (19, 1))
        out.append(shape[0] + np.concatenate([np.zeros((1, 2)), np.cumsum(seg, axis=0)]))
    return np.asarray(out, dtype=np.float32)


def _lengths(shapes: np.ndarray) -> np.ndarray:
    return np.linalg.norm(np.diff(shapes.astype(np.float64), axis=1), axis=-1)


def test_segments_come_to_the_rest_length_and_held_ends_stay():
    shapes = _stretched(32, seed=0)
    span = np.linalg.norm(shapes[:, 0] - shapes[:, -1], axis=-1)
    pin_first = np.arange(32) % 3 != 1  # head held
    pin_last = (np.arange(32) % 3 != 0) & (span < 0.9)  # both held only within the span
    before = np.abs(_lengths(shapes) - REST) / REST
    out = make_inextensible(shapes, REST, pin_first, pin_last)
    after = np.abs(_lengths(out) - REST) / REST
    assert np.median(before) > 0.05 and np.median(after) < 0.005
    converged = make_inextensible(shapes, REST, pin_first, pin_last, iterations=50)
    assert (np.abs(_lengths(converged) - REST) / REST).max() < 1e-4
    assert np.array_equal(out[pin_first, 0], shapes[pin_first, 0])
    assert np.array_equal(out[pin_last, -1], shapes[pin_last, -1])
    assert not np.array_equal(out[~pin_first, 0], shapes[~pin_first, 0])  # a free end moves


def test_it_turns_and_shifts_with_the_shape_and_reversing_the_cord_reverses_the_result():
    shapes = _stretched(16, seed=1)
    pins = np.ones(16, dtype=bool), np.zeros(16, dtype=bool)
    out = make_inextensible(shapes, REST, *pins)
    c, s = np.cos(1.1), np.sin(1.1)
    turn = np.array([[c, s], [-s, c]], dtype=np.float32)
    shift = np.array([0.1, -0.2], dtype=np.float32)
    turned = make_inextensible(shapes @ turn + shift, REST, *pins)
    assert np.abs(turned - (out @ turn + shift)).max() < 1e-5
    reversed_ = make_inextensible(shapes[:, ::-1], REST, pins[1], pins[0])[:, ::-1]
    assert np.abs(reversed_ - out).max() < 1e-6


def test_it_moves_a_shape_little_more_than_the_distance_to_a_cord_it_is_near():
    # A cord with rest-length segments, every point jittered by 2 mm: the projection lands
    # about as near the jittered shape as the cord itself is (which is one such shape), and a
    # cord already at rest length stays where it is.
    rng = np.random.default_rng(3)
    cords = np.stack([random_cord_shape(rng, margin=0.3) for _ in range(16)])
    assert np.abs(_lengths(cords) - REST).max() < 1e-5
    pins = np.ones(16, dtype=bool), np.arange(16) % 2 == 0
    assert np.abs(make_inextensible(cords, REST, *pins) - cords).max() < 1e-5
    jittered = cords + rng.normal(0, 0.002, cords.shape).astype(np.float32)
    jittered[:, 0], jittered[pins[1], -1] = cords[:, 0], cords[pins[1], -1]  # held: not jittered
    out = make_inextensible(jittered, REST, *pins)
    assert (np.abs(_lengths(out) - REST) / REST).max() < 1e-3
    moved = np.linalg.norm(out - jittered, axis=-1).mean(axis=1)
    bound = np.linalg.norm(cords - jittered, axis=-1).mean(axis=1)
    assert (moved <= 1.1 * bound).all() and moved.mean() < 0.8 * bound.mean()
