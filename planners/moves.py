"""Straight moves of the grasped end as environment actions."""

from __future__ import annotations

import numpy as np

from dlo_env.errors import InputError
from dlo_env.shapes import TABLE_HALF
from dlo_env.tasks import split_move

#: Corners are kept this far inside the table edge, metres (the cord's default ``rim_margin``).
EDGE_MARGIN = 0.02


def actions_by_move(
    end: np.ndarray, corners: np.ndarray, max_step: float
) -> list[list[np.ndarray]]:
    """Actions that move the end(s) from ``end`` straight to each of ``corners``, move by move.

    Every straight move is split into equal actions (``dlo_env.tasks.split_move``, as the
    environments' own tasks are made), so no action moves an end farther than ``max_step``
    and the ends stop exactly at every corner (both ends held: they move at once, each in a
    straight line). Corners are clipped to the table; a corner less than a micrometre from
    the previous one gives an empty move.

    Args:
        end: ``(2,)`` the end's position now, metres; ``(E, 2)`` for E ends held.
        corners: ``(K, 2)`` positions to visit, metres; ``(K, E, 2)`` for E ends.
        max_step: Displacement of an action of 1.0, metres.

    Returns:
        ``K`` lists of float32 ``(2 E,)`` actions in ``[-1, 1]``, with every end's part of
        length ``<= 1``.
    """
    if not max_step > 0:
        raise InputError(f"max_step must be > 0, got {max_step!r}")
    lim = TABLE_HALF - EDGE_MARGIN
    here = np.asarray(end, dtype=np.float64).reshape(-1)
    width = here.size
    moves: list[list[np.ndarray]] = []
    for corner in np.clip(np.asarray(corners, dtype=np.float64).reshape(-1, width), -lim, lim):
        displacement = corner - here
        if np.linalg.norm(displacement) < 1e-6:
            moves.append([])
            continue
        moves.append(list(split_move(displacement, max_step)))
        here = corner
    return moves


def actions_through(end: np.ndarray, corners: np.ndarray, max_step: float) -> list[np.ndarray]:
    """Actions that move the end from ``end`` straight to each of ``corners`` in turn.

    The moves of :func:`actions_by_move`, one after the other.

    Returns:
        A list of float32 ``(2 E,)`` actions in ``[-1, 1]`` (E held ends).
    """
    return [action for move in actions_by_move(end, corners, max_step) for action in move]
