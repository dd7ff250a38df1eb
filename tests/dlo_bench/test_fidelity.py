from __future__ import annotations

import numpy as np
import pytest

from dlo_bench import transition_fidelity
from dlo_env.cord import Cord
from dlo_env.tasks import apply_action, split_move
from planners import Plan


def _straight_start() -> np.ndarray:
    return np.stack([np.linspace(-0.5, 0.5, 20), np.zeros(20)], axis=1).astype(np.float32)


def _recorded_plan(start: np.ndarray, moves: list[tuple[float, float]]) -> Plan:
    """A plan whose shapes are what the simulator does, recorded at every action."""
    cord = Cord(grasp="head")
    cord.reset(start)
    shapes, heads, nodes = [cord.shape], [cord.gripper_positions()["head"]], [0]
    for move in moves:
        for action in split_move(np.array(move), 0.02):
            apply_action(cord, action, 0.02)
            shapes.append(cord.shape)
            heads.append(cord.gripper_positions()["head"])
        nodes.append(len(shapes) - 1)
    n = len(shapes)
    return Plan(shapes=np.array(shapes), latents=np.zeros((n, 1), np.float32),
                waypoints=np.array(heads, dtype=np.float32), nodes=np.array(nodes), success=True)


def test_a_plan_that_predicts_the_simulator_exactly_has_zero_fidelity_error():
    start = _straight_start()
    plan = _recorded_plan(start, [(-0.1, 0.12), (0.08, 0.05)])
    result = transition_fidelity(plan, start)
    assert result.errors.shape == (len(plan.shapes),)
    assert result.mean_error < 1e-4
    assert result.final_error < 2e-3  # the cord barely moves while settling


def test_fidelity_measures_how_far_the_planned_shapes_are_from_the_real_ones():
    start = _straight_start()
    plan = _recorded_plan(start, [(0.0, 0.1)])
    shifted = Plan(shapes=plan.shapes + np.float32(0.03), latents=plan.latents,
                   waypoints=plan.waypoints, nodes=plan.nodes, success=True)
    result = transition_fidelity(shifted, start)
    np.testing.assert_allclose(result.errors, 0.03 * np.sqrt(2.0), atol=2e-4)
    assert result.mean_error == pytest.approx(0.03 * np.sqrt(2.0), abs=2e-4)


def test_fidelity_matches_shapes_at_their_waypoints_between_recorded_steps():
    start = _straight_start()
    plan = _recorded_plan(start, [(0.0, 0.1)])
    # Keep only the start, the middle of the move (between two recorded steps) and the end.
    mid = 0.5 * (plan.shapes[2] + plan.shapes[3])
    mid_head = 0.5 * (plan.waypoints[2] + plan.waypoints[3])
    coarse = Plan(shapes=np.stack([plan.shapes[0], mid, plan.shapes[-1]]),
                  latents=np.zeros((3, 1), np.float32),
                  waypoints=np.stack([plan.waypoints[0], mid_head, plan.waypoints[-1]]),
                  nodes=np.array([0, 2]), success=True)
    result = transition_fidelity(coarse, start)
    assert result.max_error < 1e-4


def test_fidelity_rejects_a_start_of_the_wrong_shape():
    start = _straight_start()
    plan = _recorded_plan(start, [(0.0, 0.1)])
    with pytest.raises(ValueError, match="start must have shape"):
        transition_fidelity(plan, start[:10])


def test_fidelity_says_how_far_the_end_had_travelled_and_in_which_move_at_every_shape():
    start = _straight_start()
    plan = _recorded_plan(start, [(0.0, 0.1), (0.06, 0.0)])
    result = transition_fidelity(plan, start)
    assert result.travel[0] == 0.0 and np.all(np.diff(result.travel) >= 0)
    assert result.travel[-1] == pytest.approx(plan.path_length, abs=1e-6)
    assert result.travel[plan.nodes[1]] == pytest.approx(0.1, abs=1e-4)
    expected_move = np.r_[0, np.zeros(plan.nodes[1]), np.ones(plan.nodes[2] - plan.nodes[1])]
    np.testing.assert_array_equal(result.move, expected_move)
