"""Shape arguments and ``dlo_env`` observations as the planners read them.

A ``dlo_env`` goal environment observes a Dict: ``observation`` (the flat shape followed by the
held grippers' positions and, in an environment with ``max_pegs`` > 0, that many peg centres and
their mask), ``achieved_goal`` (the flat shape) and ``desired_goal`` (the flat goal).
Stable-Baselines3 and ``gym.make_vec`` pass the same Dict with a leading batch axis, one row per
environment.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dlo_env.errors import InputError
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
        head: ``(2,)`` the first held gripper's position (the head point if the observation
            does not give the grippers).
        grippers: ``(k, 2)`` the held grippers' positions, head first; ``(0, 2)`` when the
            observation gives only ``achieved_goal`` and ``desired_goal``.
        pegs: ``(m, 2)`` the centres of the pegs on the table (``(0, 2)``: none).
    """

    shape: np.ndarray
    goal: np.ndarray
    head: np.ndarray
    grippers: np.ndarray
    pegs: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.float32))


def _check_dict(observation: Any) -> None:
    if not isinstance(observation, dict) or not {"achieved_goal", "desired_goal"} <= set(
        observation
    ):
        got = sorted(observation) if isinstance(observation, dict) else type(observation).__name__
        raise InputError(
            "observation must be a dict with 'achieved_goal' and 'desired_goal' (a dlo_env goal "
            f"environment's observation), got {got}"
        )


def split_batch(observation: Any) -> tuple[list[dict[str, np.ndarray]], bool]:
    """The observations of each environment in ``observation``, and whether it was batched.

    An unbatched observation (flat arrays, as ``env.reset`` returns) is one environment; a
    batched one (a leading axis, as SB3 and ``gym.make_vec`` pass) holds one row per
    environment.

    Raises:
        ValueError: When ``observation`` is not a goal observation or its arrays disagree on
            the batch size.
    """
    _check_dict(observation)
    arrays = {key: np.asarray(value) for key, value in observation.items()}
    if arrays["achieved_goal"].ndim < 2:
        return [arrays], False
    size = arrays["achieved_goal"].shape[0]
    for key, value in arrays.items():
        if value.ndim < 2 or value.shape[0] != size:
            raise InputError(
                f"observation[{key!r}] must have the batch's leading axis of {size} (as "
                f"observation['achieved_goal']), got shape {value.shape}"
            )
    return [{key: value[i] for key, value in arrays.items()} for i in range(size)], True


def read_observation(observation: Any, n_points: int) -> CordObservation:
    """Unpack one environment's Dict observation (optionally with a batch axis of one).

    Raises:
        ValueError: When keys are missing, the batch holds more than one observation (split
            it with :func:`split_batch`), or the sizes do not match ``n_points`` (e.g. a model
            made for another cord).
    """
    _check_dict(observation)
    achieved = np.asarray(observation["achieved_goal"], dtype=np.float32)
    desired = np.asarray(observation["desired_goal"], dtype=np.float32)
    if achieved.ndim == 2 and achieved.shape[0] != 1:
        raise InputError(
            f"observation must hold one environment (batch of 1), got a batch of "
            f"{achieved.shape[0]}: split it with planners.observation.split_batch"
        )
    flat = achieved.reshape(-1)
    if flat.size != 2 * n_points:
        raise InputError(
            f"observation['achieved_goal'] has {flat.size} numbers, but the model's cord has "
            f"n_points={n_points} ({2 * n_points} numbers): the model and the environment "
            "must be made for the same cord"
        )
    shape = as_shape(flat, n_points, "observation['achieved_goal']")
    goal = as_shape(desired.reshape(-1), n_points, "observation['desired_goal']")
    grippers = pegs = np.zeros((0, 2), dtype=np.float32)
    extra = observation.get("observation")
    if extra is not None:
        extra = np.asarray(extra, dtype=np.float32).reshape(-1)
        # After the shape: 2 numbers per held end (1 or 2), then 3 per peg slot (centre, mask),
        # so what is left modulo 3 tells the held ends apart (2: one end, 1: two, 0: none).
        rest = extra.size - 2 * n_points
        held = {0: 0, 2: 1, 1: 2}[rest % 3] if rest > 0 else 0
        slots = (rest - 2 * held) // 3
        at = 2 * n_points + 2 * held
        grippers = extra[2 * n_points : at].reshape(held, 2).copy()
        if slots > 0:
            mask = extra[at + 2 * slots : at + 3 * slots] > 0.5
            pegs = extra[at : at + 2 * slots].reshape(slots, 2)[mask].copy()
    head = grippers[0].copy() if len(grippers) else shape[0].copy()
    return CordObservation(shape=shape, goal=goal, head=head, grippers=grippers, pegs=pegs)
