"""Shape arguments and ``dlo_env`` observations as the planners read them.

A ``dlo_env`` goal environment observes a Dict: ``observation`` (the flat shape followed by the
held grippers' positions), ``achieved_goal`` (the flat shape) and ``desired_goal`` (the flat
goal). Stable-Baselines3 passes the same Dict with a leading batch axis of one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from dlo_env.shapes import as_points


def as_shape(value: Any, n_points: int, name: str = "shape") -> np.ndarray:
    """``value`` as a float32 ``(n_points, 2)`` shape; accepts ``(n, 2)`` or flat ``(2n,)``.

    Raises:
        ValueError: Naming ``name`` when the size is wrong or a coordinate is not finite.
    """
    return as_points(value, n_points, name,
                     context=f" to match the model's n_points={n_points}")


@dataclass(frozen=True)
class CordObservation:
    """One observation of a ``dlo_env`` goal environment, unpacked.

    Attributes:
        shape: ``(n, 2)`` the cord now.
        goal: ``(n, 2)`` the goal shape.
        head: ``(2,)`` the head gripper's position (the head point if the gripper is not given).
        batched: Whether the observation came with a leading batch axis (SB3 style).
    """

    shape: np.ndarray
    goal: np.ndarray
    head: np.ndarray
    batched: bool


def read_observation(observation: Any, n_points: int) -> CordObservation:
    """Unpack a Dict observation (optionally with a batch axis of one) for ``n_points`` cords.

    Raises:
        ValueError: When keys are missing, the batch holds more than one observation, or the
            sizes do not match ``n_points`` (e.g. a model made for another cord).
    """
    if not isinstance(observation, dict) or not {"achieved_goal", "desired_goal"} <= set(
        observation
    ):
        got = sorted(observation) if isinstance(observation, dict) else type(observation).__name__
        raise ValueError(
            "observation must be a dict with 'achieved_goal' and 'desired_goal' (a dlo_env goal "
            f"environment's observation), got {got}"
        )
    achieved = np.asarray(observation["achieved_goal"], dtype=np.float32)
    desired = np.asarray(observation["desired_goal"], dtype=np.float32)
    batched = achieved.ndim == 2
    if batched and achieved.shape[0] != 1:
        raise ValueError(
            f"observation must hold one environment (batch of 1), got a batch of "
            f"{achieved.shape[0]}"
        )
    flat = achieved.reshape(-1)
    if flat.size != 2 * n_points:
        raise ValueError(
            f"observation['achieved_goal'] has {flat.size} numbers, but the model's cord has "
            f"n_points={n_points} ({2 * n_points} numbers): the model and the environment "
            "must be made for the same cord"
        )
    shape = as_shape(flat, n_points, "observation['achieved_goal']")
    goal = as_shape(desired.reshape(-1), n_points, "observation['desired_goal']")
    head = shape[0].copy()
    extra = observation.get("observation")
    if extra is not None:
        extra = np.asarray(extra, dtype=np.float32).reshape(-1)
        if extra.size >= 2 * n_points + 2:
            head = extra[2 * n_points : 2 * n_points + 2].copy()
    return CordObservation(shape=shape, goal=goal, head=head, batched=batched)
