"""Specification of the cord simulator: its API and the physical behaviour the project needs."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from dlo_env.cord import Cord, CordParams
from dlo_env.shapes import (
    TABLE_HALF,
    error,
    is_cord_like,
    max_error,
    random_cord_shape,
    segment_lengths,
)
from dlo_env.tasks import random_start

P = CordParams()
STEP = P.max_speed * P.dt  # the farthest a gripper goes in one control period


def straight(y: float = 0.0) -> np.ndarray:
    x = -0.5 + P.segment * np.arange(P.n_points)
    return np.stack([x, np.full(P.n_points, y)], axis=1).astype(np.float32)


def max_speed_direction(rng: np.random.Generator, ends: int) -> list[np.ndarray]:
    angle = rng.uniform(-np.pi, np.pi, size=ends)
    return [STEP * np.array([np.cos(a), np.sin(a)]) for a in angle]


def test_cord_params_reject_nonsense_naming_the_field():
    with pytest.raises(ValueError, match="length"):
        CordParams(length=0.0)
    with pytest.raises(ValueError, match="n_points"):
        CordParams(n_points=2)
    with pytest.raises(ValueError, match="max_span"):
        CordParams(max_span=1.5)
    with pytest.raises(ValueError, match="velocity_retention"):
        CordParams(velocity_retention=1.5)
    with pytest.raises(ValueError, match="joint_error_bias"):
        CordParams(joint_error_bias=0.0)


def test_reset_places_the_cord_in_the_shape_and_reads_float32_points():
    cord = Cord()
    cord.reset(straight(0.3))
    assert cord.shape.dtype == np.float32 and cord.shape.shape == (P.n_points, 2)
    np.testing.assert_allclose(cord.shape, straight(0.3), atol=1e-6)
    np.testing.assert_allclose(cord.gripper_positions()["head"], straight(0.3)[0], atol=1e-6)


def test_using_the_cord_before_reset_raises():
    with pytest.raises(RuntimeError, match="reset"):
        Cord().move(head=(0.01, 0.0))


def test_unknown_grasp_and_non_finite_displacement_raise():
    with pytest.raises(ValueError, match="grasp"):
        Cord(grasp="middle")
    cord = Cord()
    cord.reset(straight())
    with pytest.raises(ValueError, match="head displacement must be finite"):
        cord.move(head=(np.nan, 0.0))


def test_same_reset_and_moves_give_bitwise_identical_shapes():
    rng = np.random.default_rng(0)
    start = random_cord_shape(rng)
    moves = rng.uniform(-0.03, 0.03, size=(15, 2))
    runs = []
    for _ in range(2):
        cord = Cord()
        cord.reset(start)
        runs.append(np.stack([cord.move(head=m, record_every=5)[-1] for m in moves]))
    assert np.array_equal(runs[0], runs[1])


def test_a_move_takes_whole_control_periods_at_bounded_speed():
    cord = Cord()
    cord.reset(straight())
    assert len(cord.move(head=(STEP, 0.0), record_every=P.substeps)) == 1
    assert len(cord.move(head=(0.0, 2.5 * STEP), record_every=P.substeps)) == 3
    np.testing.assert_allclose(cord.gripper_positions()["head"], [-0.5 + STEP, 2.5 * STEP])


def test_grippers_are_clipped_to_the_table():
    cord = Cord()
    cord.reset(straight())
    cord.move(head=(-5.0, 0.0))
    lim = TABLE_HALF - P.rim_margin
    np.testing.assert_allclose(cord.gripper_positions()["head"], [-lim, 0.0], atol=1e-9)


def test_both_grippers_stay_within_max_span():
    cord = Cord(grasp="both")
    cord.reset(random_start(3, "both"))
    cord.move(head=(-0.5, 0.0), tail=(0.5, 0.0))
    g = cord.gripper_positions()
    assert np.linalg.norm(g["tail"] - g["head"]) == pytest.approx(P.max_span * P.length)


def test_set_grasp_attaches_a_gripper_where_the_end_lies():
    cord = Cord(grasp="none")
    cord.reset(straight())
    assert cord.gripper_positions() == {}
    cord.set_grasp("tail")
    np.testing.assert_allclose(cord.gripper_positions()["tail"], straight()[-1], atol=1e-6)


# ------------------------------------------------------------------- physical behaviour


@pytest.mark.parametrize("grasp", ["head", "both"])
def test_segments_stay_within_2_percent_of_rest_length_at_max_gripper_speed(grasp):
    rng = np.random.default_rng(1)
    ends = 2 if grasp == "both" else 1
    worst = 0.0
    for _ in range(8):
        cord = Cord(grasp=grasp)
        cord.reset(random_start(rng, grasp))
        for _ in range(40):  # every move at exactly max speed, every substep recorded
            d = max_speed_direction(rng, ends)
            shapes = cord.move(*d, record_every=1)
            stretch = np.abs(segment_lengths(shapes) / P.segment - 1.0).max()
            worst = max(worst, float(stretch))
    assert worst <= 0.02


def test_cord_comes_to_rest_within_half_a_second_after_the_grippers_stop():
    rng = np.random.default_rng(2)
    for grasp, ends in (("head", 1), ("both", 2)):
        for _ in range(4):
            cord = Cord(grasp=grasp)
            cord.reset(random_start(rng, grasp))
            for _ in range(10):
                cord.move(*max_speed_direction(rng, ends))
            assert np.linalg.norm(cord.point_velocities(), axis=1).max() > 1e-3  # was moving
            took = cord.settle(tolerance=1e-3, max_time=0.5)
            assert took < 0.5
            assert np.linalg.norm(cord.point_velocities(), axis=1).max() < 1e-3


def test_point_velocities_are_the_links_rigid_motion_and_max_point_speed_their_largest_norm():
    rng = np.random.default_rng(5)
    cord = Cord(grasp="both")
    cord.reset(random_start(rng, "both"))
    cord.move(*max_speed_direction(rng, 2))
    v = cord.point_velocities()
    assert np.abs(v).max() > 1e-3  # moving
    # Finite differences of the points over one tiny physics step agree with the velocities.
    before = cord.shape.astype(np.float64)
    h = 1e-5
    cord.space.step(h)
    fd = (cord.shape.astype(np.float64) - before) / h
    assert np.abs(fd - v).max() < 0.02 * np.abs(v).max() + 2e-3
    assert cord.max_point_speed() == np.linalg.norm(cord.point_velocities(), axis=1).max()


def test_settle_relaxes_a_freshly_reset_bent_cord():
    # Zero velocity right after reset is not rest: the bent joints push against friction.
    bent = random_cord_shape(np.random.default_rng(4))
    cord = Cord(grasp="none")
    cord.reset(bent)
    took = cord.settle()
    assert took > 0.1
    assert error(bent, cord.shape) > 1e-3


@pytest.mark.slow
def test_ten_thousand_random_actions_stay_finite_and_on_the_table():
    rng = np.random.default_rng(5)
    lim = TABLE_HALF - P.rim_margin
    worst, clipped = 0.0, 0
    for grasp, ends, actions in (("head", 1, 7000), ("both", 2, 3000)):
        cord = Cord(grasp=grasp)
        cord.reset(random_start(rng, grasp))
        for _ in range(actions):  # the environments' action range: a random walk to the rim
            cord.move(*rng.uniform(-STEP, STEP, size=(ends, 2)))
            shape = cord.shape
            assert np.isfinite(shape).all()
            worst = max(worst, float(np.abs(shape).max()))
            grip = np.array(list(cord.gripper_positions().values()))
            assert (np.abs(grip) <= lim + 1e-9).all()
            clipped += int((np.abs(grip) >= lim - 1e-9).any())
    assert clipped > 50  # the grippers did run into the table's limit
    assert worst <= TABLE_HALF


@pytest.mark.slow
def test_the_rim_is_hard_under_ten_thousand_actions_driven_into_every_edge_and_corner():
    # Each grasp drives its ends at full speed towards an edge or a corner (all eight in turn,
    # with noise), so the cord is dragged along the walls and pushed into the corners.
    rng = np.random.default_rng(11)
    headings = [np.array(v, dtype=float) for v in
                ((1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1))]
    worst, near_rim, actions = 0.0, 0, 0
    for grasp, ends in (("head", 1), ("tail", 1), ("both", 2)):
        cord = Cord(grasp=grasp)
        for episode in range(16):
            cord.reset(random_cord_shape(rng, margin=0.0))
            for k in range(210):
                if k % 70 == 0:
                    aim = [headings[(episode + k // 70 + 3 * e) % 8] for e in range(ends)]
                moves = [STEP * (a / np.linalg.norm(a) + 0.3 * rng.normal(size=2)) for a in aim]
                recorded = cord.move(*moves, record_every=5)
                shapes = np.concatenate([recorded, cord.shape[None]])
                worst = max(worst, float(np.abs(shapes).max()))
                near_rim += int((np.abs(shapes[-1]) > TABLE_HALF - 0.03).any())
                actions += 1
    assert actions >= 10_000
    assert near_rim > 3000  # the cord really was pressed against the rim
    assert worst <= TABLE_HALF


def test_path_dependence_two_paths_to_the_same_end_position_leave_different_shapes():
    # Friction makes the shape depend on the path: pulling the head straight to a point
    # and going there via a detour end with the gripper at the same place, shapes different.
    start = straight()
    finals = []
    for path in ([(0.0, 0.3)], [(0.3, 0.0), (0.0, 0.3), (-0.3, 0.0)]):
        cord = Cord()
        cord.reset(start)
        for d in path:
            cord.move(head=d)
        cord.settle()
        np.testing.assert_allclose(cord.gripper_positions()["head"], [-0.5, 0.3], atol=1e-9)
        finals.append(cord.shape)
    assert error(*finals) > 0.02
    assert max_error(*finals) > 0.05


def test_at_least_half_of_the_shapes_under_random_manipulation_are_cord_like():
    rng = np.random.default_rng(6)
    seen = []
    for grasp, ends in (("head", 1), ("both", 2)):
        for _ in range(10):
            cord = Cord(grasp=grasp)
            cord.reset(random_start(rng, grasp))
            for _ in range(5):  # random straight moves of 5-30 cm, as in the tasks
                angle = rng.uniform(-np.pi, np.pi, size=ends)
                length = rng.uniform(0.05, 0.30, size=ends)
                d = length[:, None] * np.stack([np.cos(angle), np.sin(angle)], axis=1)
                seen.append(cord.move(*d, record_every=P.substeps))
    shapes = np.concatenate(seen)
    fraction = float(np.mean(is_cord_like(shapes)))
    assert len(shapes) > 500
    assert fraction >= 0.5


def test_pickled_cord_continues_within_a_millimetre():
    # pymunk pickles bodies and velocities but not the solver's cached impulses: the copy
    # continues close to the original, not bitwise (documented in the README).
    rng = np.random.default_rng(7)
    cord = Cord()
    cord.reset(random_start(rng))
    for _ in range(10):
        cord.move(head=rng.uniform(-0.02, 0.02, size=2))
    copy = pickle.loads(pickle.dumps(cord))
    assert np.array_equal(copy.shape, cord.shape)
    for d in rng.uniform(-0.02, 0.02, size=(20, 2)):
        cord.move(head=d)
        copy.move(head=d)
    assert max_error(copy.shape, cord.shape) < 1e-3
    assert error(copy.shape, cord.shape) < 5e-4
