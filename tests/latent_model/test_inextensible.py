"""Specification of latent_model.inextensible (predictions moved onto rest-length segments)."""

from __future__ import annotations

import numpy as np

from dlo_env.shapes import random_cord_shape
from latent_model.inextensible import ITERATIONS, MAX_MOVE, make_inextensible

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
    mixed = np.arange(16) % 2 == 0, np.arange(16) % 3 == 0  # some held at both ends
    mixed[1][np.linalg.norm(shapes[:, 0] - shapes[:, -1], axis=-1) > 0.9] = False
    out = make_inextensible(shapes, REST, *mixed)
    reversed_ = make_inextensible(shapes[:, ::-1], REST, mixed[1], mixed[0])[:, ::-1]
    assert np.abs(reversed_ - out).max() < 1e-5


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


def test_a_slack_cord_held_at_both_ends_comes_to_length_in_bounded_steps():
    # Held at both ends 0.8-0.9 m apart and nearly straight (bows 1 mm to 5 cm high), or the
    # mean of a bow and its mirror image: the lengths barely change with moves across the
    # cord, so an unbounded step flies off; each step moves a point half a segment at most.
    t = np.linspace(0.0, 1.0, 20)
    bows = [np.stack([span * t, 4 * height * t * (1 - t)], axis=-1)
            for span in (0.8, 0.9) for height in (0.001, 0.005, 0.02, 0.05)]
    half = np.stack([np.sin(np.pi * (t - 0.5)), np.cos(np.pi * (t - 0.5))], axis=-1) / np.pi
    bows.append(0.6 * half + 0.4 * half * [1.0, -1.0])  # a half circle leaning 60/40
    shapes = np.asarray(bows, dtype=np.float32)
    held = np.ones(len(shapes), dtype=bool)
    out = make_inextensible(shapes, REST, held, held)
    assert (np.abs(_lengths(out) - REST) / REST).max() < 1e-3
    assert np.array_equal(out[:, [0, -1]], shapes[:, [0, -1]])
    assert np.linalg.norm(out - shapes, axis=-1).max() <= ITERATIONS * MAX_MOVE * REST + 1e-6
    # Exactly straight, held: it cannot leave the line but stays finite and in place.
    for span in (0.8, 1.0, 1.05):
        line = np.stack([span * t, 0 * t], axis=-1)[None].astype(np.float32)
        kept = make_inextensible(line, REST, np.ones(1, dtype=bool), np.ones(1, dtype=bool))
        assert np.isfinite(kept).all() and np.abs(kept - line).max() < 1e-4


def test_short_cords_and_an_empty_batch():
    assert make_inextensible(np.zeros((0, 20, 2)), REST, np.zeros(0, bool),
                             np.zeros(0, bool)).shape == (0, 20, 2)
    for n in (2, 3):
        shapes = np.random.default_rng(n).normal(0, 0.05, (4, n, 2)).astype(np.float32)
        for pins in ((False, False), (True, False), (False, True)):
            out = make_inextensible(shapes, REST, np.full(4, pins[0]), np.full(4, pins[1]),
                                    iterations=40)
            assert np.abs(_lengths(out) - REST).max() < 1e-4
        both = make_inextensible(shapes[:, :2], REST, np.ones(4, bool), np.ones(4, bool))
        assert np.array_equal(both, shapes[:, :2])  # nothing free to move
