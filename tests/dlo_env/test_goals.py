"""Designed goals: drawings resampled to the cord, placed on the table and relaxed."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import dlo_env  # noqa: F401  (registers the environments)
from dlo_env import goals
from dlo_env.cord import CordParams
from dlo_env.shapes import bead_share, error, segment_lengths

SOFT = CordParams(bending_stiffness=0.001)  # a cord that rests in letters of its own length


def test_a_drawing_is_resampled_on_itself_with_the_cords_spacing_and_placed_at_the_pose():
    drawing = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 2.0]])  # any units: scaled to the cord
    for angle in (0.0, 0.5, np.pi / 2):
        shape = goals.polyline(drawing, center=(0.2, -0.1), angle=angle, relax=False,
                               rounding=0)
        assert shape.shape == (20, 2) and shape.dtype == np.float32
        np.testing.assert_allclose(segment_lengths(shape), 1.0 / 19, atol=1e-6)
        np.testing.assert_allclose(0.5 * (shape.min(axis=0) + shape.max(axis=0)), [0.2, -0.1],
                                   atol=1e-6)  # the placed shape's bounding box, at any angle
        # Undo the pose: every point lies on the drawing (scaled), the ends on its ends.
        c, s = np.cos(angle), np.sin(angle)
        back = (shape - shape[0]) @ np.array([[c, -s], [s, c]])
        back *= np.hypot(3.0, 2.0) / np.linalg.norm(back[-1])  # in the drawing's units
        on_leg = np.minimum(np.abs(back[:, 1]) + (back[:, 0] > 3 + 1e-4),
                            np.abs(back[:, 0] - 3) + (back[:, 1] < -1e-4))
        assert on_leg.max() < 1e-4
        np.testing.assert_allclose(back[-1], [3.0, 2.0], atol=1e-4)
    turned = goals.polyline(drawing, angle=np.pi / 2, relax=False, rounding=0)
    assert turned[5, 1] > turned[0, 1]  # a quarter turn counter-clockwise: +x becomes +y


def test_a_gentle_arc_relaxes_close_to_its_drawing_and_is_a_goal_of_both_environments():
    raw = goals.arc(1.5, relax=False)
    goal = goals.arc(1.5)
    assert error(goal, raw) < 0.01
    for env_id, grasp in (("dlo_env/DLOEndpoint-v0", "head"),
                          ("dlo_env/DLODualEndpoint-v0", "both")):
        env = gym.make(env_id)
        goal = goals.arc(2.5, grasp=grasp)  # ends 0.76 m apart: within the span
        obs, _ = env.reset(seed=0, options={"goal": goal})
        np.testing.assert_allclose(obs["desired_goal"], goal.reshape(-1))


def test_letters_and_curves_relax_into_shapes_a_soft_cord_rests_in():
    env = gym.make("dlo_env/DLOEndpoint-v0", params=SOFT)
    for name in goals.LETTERS:
        raw = goals.letter(name, params=SOFT, relax=False)
        goal = goals.letter(name, params=SOFT)
        assert error(goal, raw) < 0.015 and bead_share(goal, raw) >= 0.9, name
        env.reset(seed=0, options={"goal": goal})  # a goal the environment takes
    for name, make in goals.CURVES.items():
        assert error(make(params=SOFT), make(params=SOFT, relax=False)) < 0.015, name


def test_a_drawing_the_cord_cannot_rest_in_is_refused_saying_why():
    # The default cord springs open out of a letter-sized S (docs/tasks.md's table).
    with pytest.raises(ValueError, match="points must draw a shape the cord can rest in: it "
                                         "relaxes .* cm from the drawing"):
        goals.letter("S")
    with pytest.raises(ValueError, match="folds back on itself in less than one segment"):
        goals.polyline([[i % 2, 0] for i in range(41)])  # a scribble finer than a segment


def test_the_letter_o_is_a_ring_whose_ends_meet_and_aspect_widens_a_letter():
    o = goals.letter("O", params=SOFT, relax=False)
    segment = SOFT.length / (SOFT.n_points - 1)
    assert np.linalg.norm(o[-1] - o[0]) < segment
    narrow, wide = (goals.letter("U", aspect=a, params=SOFT, relax=False) for a in (0.8, 1.25))
    assert np.ptp(wide[:, 0]) / np.ptp(wide[:, 1]) > np.ptp(narrow[:, 0]) / np.ptp(narrow[:, 1])


@pytest.mark.parametrize(("call", "match"), [
    (lambda: goals.letter("U", aspect=0.1), r"aspect must be a number in \[0.25, 4\]"),
    (lambda: goals.letter("Q"), "name must be one of the letters C, J, L, M, S, U, V, W, Z, O"),
    (lambda: goals.polyline([[0.0, 0.0]]), r"points must be a \(k, 2\) polyline with k >= 2"),
    (lambda: goals.polyline([[0.0, 0.0], [np.nan, 1.0]]), "points must be finite"),
    (lambda: goals.polyline([[1.0, 1.0], [1.0, 1.0]]), "must not all be the same point"),
    (lambda: goals.arc(1.0, center=(0.9, 0.0)), "center and angle must keep the goal on the"),
    (lambda: goals.polyline([[0, 0], [1, 0]], grasp="both"), "closer than the grippers' span"),
    (lambda: goals.arc(7.0), r"span must be a number in \(0, 2 pi\)"),
    (lambda: goals.zigzag(teeth=0), "teeth must be an int in 1..8"),
    (lambda: goals.spiral(turns=9), r"turns must be a number in \[0.25, 3\]"),
    (lambda: goals.s_curve(amplitude=-1), r"amplitude must be a number in \(0, 1\]"),
    (lambda: goals.arc(1.0, grasp="middle"), "grasp must be one of"),
    (lambda: goals.arc(1.0, center=(0.0,)), "center must be two finite numbers"),
    (lambda: goals.arc(1.0, center=None), "center must be two finite numbers"),
    (lambda: goals.arc(1.0, angle="x"), "angle must be a finite number"),
    (lambda: goals.polyline("ab"), "points must be a"),
    (lambda: goals.arc(1.0, params="soft"), "params must be a CordParams"),
    (lambda: goals.arc(1.0, rounding=True), "rounding must be an int in 0..8"),
])
def test_bad_drawings_and_poses_get_one_line_naming_the_argument(call, match):
    with pytest.raises(ValueError, match=match) as info:
        call()
    assert "\n" not in str(info.value)
