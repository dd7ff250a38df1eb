"""Specification of dlo_env.shapes: distances, the cord-like filter, validation, drawing."""

from __future__ import annotations

import numpy as np
import pytest

from dlo_env.shapes import (
    BEAD_TOLERANCE,
    COSINE_THRESHOLD,
    bead_share,
    cord_length,
    direction_free_error,
    error,
    is_cord_like,
    max_error,
    on_table,
    random_cord_shape,
    segment_lengths,
    spacing_cv,
    turning_cosines,
    validate_shape,
    wavy_cord_shape,
    wide_cord_shape,
)

N, LENGTH = 20, 1.0
SEG = LENGTH / (N - 1)


def straight(n: int = N, origin: tuple[float, float] = (-0.5, 0.0)) -> np.ndarray:
    x = origin[0] + SEG * np.arange(n)
    return np.stack([x, np.full(n, origin[1])], axis=1).astype(np.float32)


def test_error_of_a_translated_shape_is_the_translation_length():
    a = straight()
    assert error(a, a) == 0.0
    assert error(a, a + np.array([0.03, 0.04])) == pytest.approx(0.05)


def test_error_is_the_mean_and_max_error_the_largest_point_distance():
    a = straight()
    b = a.copy()
    b[0, 1] += 0.2
    assert error(a, b) == pytest.approx(0.2 / N)
    assert max_error(a, b) == pytest.approx(0.2)


def test_error_and_max_error_work_on_batches():
    a = np.stack([straight(), straight() + 0.1])
    b = straight()
    assert np.asarray(error(a, b)).shape == (2,)
    np.testing.assert_allclose(error(a, b), [0.0, np.hypot(0.1, 0.1)], atol=1e-6)
    np.testing.assert_allclose(max_error(a, b), [0.0, np.hypot(0.1, 0.1)], atol=1e-6)


def test_error_and_max_error_take_flat_shapes_as_observations_hold_them():
    a = np.stack([straight(), straight() + 0.1])
    b = straight() + np.array([0.0, 0.05])
    np.testing.assert_allclose(error(a.reshape(2, -1), b.reshape(-1)), error(a, b))
    np.testing.assert_allclose(max_error(a.reshape(2, -1), b), max_error(a, b))
    assert error(a[1].reshape(-1), b.reshape(-1)) == pytest.approx(error(a[1], b))


def test_a_straight_cord_is_cord_like_and_a_right_angle_is_not():
    bent = straight()
    bent[10:, 0] = bent[9, 0]
    bent[10:, 1] = SEG * np.arange(1, N - 9)
    assert is_cord_like(straight())
    assert not is_cord_like(bent)
    assert is_cord_like(np.stack([straight(), bent])).tolist() == [True, False]


def test_cord_like_threshold_is_the_papers_and_is_checked():
    assert COSINE_THRESHOLD == 0.25
    with pytest.raises(ValueError, match="threshold"):
        is_cord_like(straight(), threshold=1.5)


def test_turning_cosine_of_a_zero_length_segment_is_zero():
    s = straight()
    s[1] = s[0]
    assert turning_cosines(s)[0] == 0.0


def test_segment_lengths_cord_length_and_spacing_of_a_straight_cord():
    s = straight()
    np.testing.assert_allclose(segment_lengths(s), SEG, rtol=1e-5)
    assert cord_length(s) == pytest.approx(LENGTH, rel=1e-5)
    assert spacing_cv(s) == pytest.approx(0.0, abs=1e-5)


def test_on_table_checks_every_point():
    s = straight()
    assert on_table(s)
    s[3, 1] = 1.01
    assert not on_table(s)


def test_validate_shape_accepts_flat_and_returns_float32_points():
    out = validate_shape(straight().reshape(-1).astype(np.float64), n_points=N, length=LENGTH)
    assert out.dtype == np.float32 and out.shape == (N, 2)


@pytest.mark.parametrize(
    ("shape", "match"),
    [
        (np.zeros((N, 3)), r"start must have shape \(20, 2\)"),
        (np.full((N, 2), np.nan), "start must be finite"),
        (straight(origin=(0.6, 0.0)), "start must lie on the table"),
        (straight() * 1.2, "start must be a cord of length 1.0"),
    ],
)
def test_validate_shape_rejects_bad_shapes_naming_the_argument(shape, match):
    with pytest.raises(ValueError, match=match):
        validate_shape(shape, n_points=N, length=LENGTH, name="start")


def _turns(shapes: np.ndarray) -> np.ndarray:
    # Signed turn at every joint, radians.
    v = np.diff(shapes.astype(np.float64), axis=-2)
    a = np.arctan2(v[..., 1], v[..., 0])
    return np.angle(np.exp(1j * np.diff(a, axis=-1)))


def _s_like(shapes: np.ndarray) -> np.ndarray:
    # Each half of the cord turns by more than 1 rad, the two halves opposite ways.
    t = _turns(shapes)
    h = t.shape[-1] // 2
    first, second = t[:, :h].sum(axis=-1), t[:, h:].sum(axis=-1)
    return (np.minimum(np.abs(first), np.abs(second)) > 1.0) & (np.sign(first) != np.sign(second))


def test_wide_cord_shape_is_seeded_cord_like_and_bends_harder_than_random_cord_shape():
    a = wide_cord_shape(np.random.default_rng(7))
    assert np.array_equal(a, wide_cord_shape(np.random.default_rng(7)))
    wide = np.stack([wide_cord_shape(np.random.default_rng(s)) for s in range(200)])
    plain = np.stack([random_cord_shape(np.random.default_rng(s)) for s in range(200)])
    assert wide.dtype == np.float32 and is_cord_like(wide).all()
    np.testing.assert_allclose(segment_lengths(wide), SEG, rtol=1e-4)
    assert np.abs(wide).max() <= 0.9 + 1e-6
    assert _s_like(wide).mean() >= max(0.04, 3 * _s_like(plain).mean())
    # Kinks: about half the shapes have a joint sharper than the smooth part can bend...
    smooth_limit = 9.0 * SEG
    assert 0.3 < (np.abs(_turns(wide)).max(axis=-1) > smooth_limit + 0.05).mean() < 0.8
    # ...and without kinks none has.
    calm = np.stack([wide_cord_shape(np.random.default_rng(s), kinks=0.0) for s in range(50)])
    assert np.abs(_turns(calm)).max() <= smooth_limit + 1e-4


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"kinks": -1.0}, "kinks must be a number >= 0, got -1.0"),
    ({"threshold": 1.5}, r"threshold must be in \[-1, 1\), got 1.5"),
])
def test_wide_cord_shape_rejects_bad_arguments_naming_them(kwargs, match):
    with pytest.raises(ValueError, match=match):
        wide_cord_shape(np.random.default_rng(0), **kwargs)


def _sign_changes(shapes: np.ndarray) -> np.ndarray:
    # How often the cord turns the other way, counting turns above 0.05 rad only.
    t = _turns(shapes)
    signs = [np.sign(row[np.abs(row) > 0.05]) for row in t]
    return np.array([int((np.diff(s) != 0).sum()) for s in signs])


def test_wavy_cord_shape_is_seeded_smooth_and_bends_both_ways_more_often():
    a = wavy_cord_shape(np.random.default_rng(7))
    assert np.array_equal(a, wavy_cord_shape(np.random.default_rng(7)))
    wavy = np.stack([wavy_cord_shape(np.random.default_rng(s)) for s in range(300)])
    plain = np.stack([random_cord_shape(np.random.default_rng(s)) for s in range(300)])
    assert wavy.dtype == np.float32 and is_cord_like(wavy).all()
    np.testing.assert_allclose(segment_lengths(wavy), SEG, rtol=1e-4)
    assert np.abs(wavy).max() <= 0.9 + 1e-6
    # Smooth: no joint turns more than the largest curvature allows...
    assert np.abs(_turns(wavy)).max() <= 9.0 * SEG + 1e-4
    # ...but the cord bends both ways, and several times, far more often than plain shapes,
    # and strong S-shapes are common.
    changes, plain_changes = _sign_changes(wavy), _sign_changes(plain)
    assert (changes >= 2).mean() >= max(0.15, 2 * (plain_changes >= 2).mean())
    assert _s_like(wavy).mean() >= max(0.03, 2 * _s_like(plain).mean())
    # One mode only is an arc: every joint turns the same way by the same angle.
    arcs = np.stack([wavy_cord_shape(np.random.default_rng(s), max_modes=1) for s in range(20)])
    t = _turns(arcs)
    np.testing.assert_allclose(t, t[:, :1].repeat(t.shape[1], axis=1), atol=1e-4)


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"max_modes": 0}, "max_modes must be an int >= 1, got 0"),
    ({"max_modes": True}, "max_modes must be an int >= 1, got True"),
    ({"threshold": 1.0}, r"threshold must be in \[-1, 1\), got 1.0"),
])
def test_wavy_cord_shape_rejects_bad_arguments_naming_them(kwargs, match):
    with pytest.raises(ValueError, match=match):
        wavy_cord_shape(np.random.default_rng(0), **kwargs)


def test_random_cord_shape_is_seeded_cord_like_exact_length_and_inside_the_margin():
    a = random_cord_shape(np.random.default_rng(7))
    b = random_cord_shape(np.random.default_rng(7))
    assert np.array_equal(a, b)
    shapes = np.stack([random_cord_shape(np.random.default_rng(s)) for s in range(50)])
    assert shapes.dtype == np.float32 and shapes.shape == (50, N, 2)
    assert is_cord_like(shapes).all()
    np.testing.assert_allclose(segment_lengths(shapes), SEG, rtol=1e-4)
    assert np.abs(shapes).max() <= 0.9 + 1e-6
    # The family is varied: not all straight, not all alike.
    assert np.ptp(np.asarray(cord_length(shapes[:, [0, -1]]))) > 0.2


def test_direction_free_error_is_the_smaller_of_the_ordered_and_reversed_errors():
    a = straight()
    np.testing.assert_allclose(direction_free_error(a, a[::-1]), 0.0, atol=1e-12)
    assert error(a, a[::-1]) > 0.4
    shifted = a + np.array([0.0, 0.03])
    assert direction_free_error(shifted, a) == pytest.approx(error(shifted, a))
    batch = np.stack([a, a[::-1]])
    np.testing.assert_allclose(direction_free_error(batch, a), [0.0, 0.0], atol=1e-12)


def test_bead_share_counts_points_within_the_tolerance_of_the_goal_polyline():
    goal = straight()  # along x
    assert bead_share(goal[::-1], goal) == 1.0  # order and direction do not matter
    near = goal + np.array([0.0, 0.5 * BEAD_TOLERANCE])
    far = goal + np.array([0.0, 2.0 * BEAD_TOLERANCE])
    assert bead_share(near, goal) == 1.0 and bead_share(far, goal) == 0.0
    half = np.concatenate([near[:10], far[10:]])
    assert bead_share(half, goal) == pytest.approx(0.5)
    # between the goal's points counts: the polyline, not its vertices
    coarse = goal[::19]  # the two end points only
    assert bead_share(goal, coarse) == 1.0
    beyond = goal + np.array([goal[-1, 0] - goal[0, 0] + 0.05, 0.0])  # on its line, past its end
    assert bead_share(beyond, goal) == 0.0
    np.testing.assert_allclose(bead_share(np.stack([near, far]), goal), [1.0, 0.0])
    with pytest.raises(ValueError, match="tolerance must be a number >= 0"):
        bead_share(goal, goal, tolerance=-1.0)
    assert bead_share(near, goal, tolerance=np.float32(0.01)) == 1.0
    with pytest.raises(ValueError, match="goal must have at least 2 points"):
        bead_share(goal, goal[:1])
