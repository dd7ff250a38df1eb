"""Transition fidelity: the planned shapes against the real cord doing the same end motion."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dlo_env.cord import PEG_RADIUS, Cord, CordParams
from dlo_env.errors import InputError
from dlo_env.shapes import error
from dlo_env.tasks import GRASP_ENDS, apply_action
from planners.interfaces import Plan
from planners.moves import actions_through
from planners.observation import as_shape


@dataclass(frozen=True)
class Fidelity:
    """How well a plan predicted the real cord.

    Attributes:
        mean_error: Mean over the planned shapes of ``error(planned, real)``, metres: the
            transition fidelity.
        errors: ``(T,)`` the error at every planned shape, metres (where they part ways).
        real_shapes: ``(T, n, 2)`` the real cord when the end was at each planned waypoint.
        final_error: ``error`` between the plan's last shape and the real cord at rest after the
            motion, metres.
        final_shape: ``(n, 2)`` the real cord at rest after the motion.
        travel: ``(T,)`` distance the end has travelled along the plan at each planned shape,
            metres (0 at the start).
        move: ``(T,)`` index of the straight move each planned shape belongs to (0 for the
            start shape and the first move).
    """

    mean_error: float
    errors: np.ndarray
    real_shapes: np.ndarray
    final_error: float
    final_shape: np.ndarray
    travel: np.ndarray
    move: np.ndarray

    @property
    def max_error(self) -> float:
        """The largest error along the path, metres."""
        return float(self.errors.max())


def transition_fidelity(
    plan: Plan,
    start: np.ndarray,
    *,
    params: CordParams | None = None,
    max_step: float = 0.02,
    settle_steps: int = 10,
    pegs: np.ndarray | None = None,
    peg_radius: float = PEG_RADIUS,
) -> Fidelity:
    """Execute a plan's end path in the simulator from ``start`` and compare shapes.

    The end moves straight from corner to corner in equal actions of at most ``max_step``, the
    environments' step primitive (``dlo_env.tasks.apply_action``), exactly as ``PlannerPolicy``
    executes an open-loop plan. Each planned shape is compared with the real cord at the moment
    the end reaches that shape's waypoint (linear interpolation between the two recorded steps
    around it), so the comparison is at matching end positions along the path.

    Args:
        plan: A plan for the manipulated end (``plan.grasp``).
        start: ``(n, 2)`` the real start shape the plan was made from.
        params: The cord's parameters (the default cord if None).
        max_step: Displacement of an action of 1.0, metres.
        settle_steps: Zero actions after the motion before ``final_shape`` is read.
        pegs: The pegs on the table (None: none).
        peg_radius: The pegs' radius, metres.

    Returns:
        The per-shape errors, their mean, and the real shapes.
    """
    params = params if params is not None else CordParams()
    start = as_shape(start, params.n_points, "start")
    if plan.shapes.shape[1] != params.n_points:
        raise InputError(f"plan must be for a cord of n_points={params.n_points}, got shapes of "
                         f"{plan.shapes.shape[1]} points")
    cord = Cord(params, grasp=plan.grasp, pegs=pegs, peg_radius=peg_radius)
    cord.reset(start)
    names = list(GRASP_ENDS[plan.grasp])
    corners = plan.corners
    waypoints = plan.waypoints
    if len(names) > 1:  # both ends: follow the end that moves farther on each edge
        lead = np.linalg.norm(np.diff(corners, axis=0), axis=-1).argmax(axis=1)
    real = np.empty_like(plan.shapes)
    real[0] = start
    zero = np.zeros(2 * len(names), dtype=np.float32)

    def held() -> np.ndarray:
        positions = cord.gripper_positions()
        return positions[names[0]] if len(names) == 1 else np.stack([positions[n]
                                                                    for n in names])

    for e in range(len(plan.nodes) - 1):
        a, b = int(plan.nodes[e]), int(plan.nodes[e + 1])
        origin = held()
        recorded = [cord.shape]
        progress = [0.0]

        for action in actions_through(origin, corners[e + 1 : e + 2], max_step):
            apply_action(cord, action, max_step)
            recorded.append(cord.shape)
            gap = held() - origin  # how far the (leading) end has come along this edge
            progress.append(float(np.linalg.norm(gap if gap.ndim == 1 else gap[lead[e]])))
        if len(names) == 1:
            chord, start_e, points = corners[e + 1] - corners[e], corners[e], waypoints
        else:
            j = lead[e]
            chord, start_e = corners[e + 1, j] - corners[e, j], corners[e, j]
            points = waypoints[:, j]
        length = float(np.linalg.norm(chord))
        idx = np.arange(a + 1, b + 1)
        if length > 1e-9:
            wanted = (points[idx] - start_e) @ (chord / length)
        else:
            wanted = np.zeros(len(idx))
        # The end may have been stopped short by the table: scale progress to the real travel.
        wanted = np.clip(wanted * (progress[-1] / max(length, 1e-9)), 0.0, progress[-1])
        rec = np.stack(recorded).astype(np.float64)
        prog = np.asarray(progress)
        for i, s in zip(idx, wanted):
            j = int(np.clip(np.searchsorted(prog, s, side="right"), 1, len(prog) - 1))
            span = prog[j] - prog[j - 1]
            w = 0.0 if span <= 1e-12 else (s - prog[j - 1]) / span
            real[i] = (1.0 - w) * rec[j - 1] + w * rec[j]
    for _ in range(settle_steps):
        apply_action(cord, zero, max_step)
    final = cord.shape
    errors = np.asarray(error(plan.shapes, real), dtype=np.float64).reshape(-1)
    steps = np.linalg.norm(np.diff(plan.waypoints.astype(np.float64), axis=0), axis=-1)
    if steps.ndim > 1:
        steps = steps.max(axis=1)
    move = np.searchsorted(plan.nodes, np.arange(len(plan.shapes)), side="left") - 1
    return Fidelity(
        mean_error=float(errors.mean()),
        errors=errors,
        real_shapes=real,
        final_error=float(error(plan.shapes[-1], final)),
        final_shape=final,
        travel=np.concatenate([[0.0], np.cumsum(steps)]),
        move=np.maximum(move, 0),
    )
