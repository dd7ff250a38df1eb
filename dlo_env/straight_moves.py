"""``StraightMoves``: one environment step is one straight move of the held end(s), then rest.

The wrapper's action is the displacement of each held end in metres (head dx, dy, then tail
dx, dy when both are held). A step carries it out exactly as tasks and the transition data do:
:func:`dlo_env.tasks.split_move` actions through the environment's own ``step``, then zero
actions until the cord is at rest (at most ``MAX_SETTLE_ACTIONS``), so a step of this wrapper is
one transition of ``dlo collect transitions``. The environment's time limit still counts
its own steps.

Example:
    >>> env = StraightMoves(gym.make("dlo_env/DLOEndpoint-v0"))
    >>> obs, reward, terminated, truncated, info = env.step(np.array([0.1, 0.0]))
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from dlo_env.errors import InputError
from dlo_env.tasks import MAX_SETTLE_ACTIONS, at_rest, split_move


class StraightMoves(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """Macro actions for a ``dlo_env`` goal environment: a straight move per step.

    Args:
        env: A ``dlo_env`` environment (``DLOEndpoint-v0`` or ``DLODualEndpoint-v0``).
        max_move: Longest displacement of an end along each axis, metres (the action bound).
    """

    def __init__(self, env: gym.Env, max_move: float = 0.5) -> None:
        if not (isinstance(max_move, (int, float)) and max_move > 0):
            raise InputError(f"max_move must be a number > 0 (metres), got {max_move!r}")
        gym.utils.RecordConstructorArgs.__init__(self, max_move=max_move)
        super().__init__(env)
        self.max_move = float(max_move)
        self.action_space = gym.spaces.Box(-self.max_move, self.max_move,
                                           shape=env.action_space.shape, dtype=np.float32)

    def step(self, action: np.ndarray) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """Move the held end(s) by ``action`` metres in a straight line, then wait for rest.

        The move is carried out whole even when the goal is reached on the way (as a recorded
        transition is); ``terminated`` says whether the cord at rest solves the goal.
        """
        move = np.asarray(action, dtype=np.float64)
        if move.shape != self.action_space.shape or not np.isfinite(move).all():
            raise InputError(f"action must be a finite array of shape "
                             f"{self.action_space.shape}, got {move.tolist()}")
        base = self.env.unwrapped
        zero = np.zeros(self.action_space.shape, dtype=np.float32)
        actions = list(split_move(move, base.max_step)) + [zero] * MAX_SETTLE_ACTIONS
        judge = base.judge_at_rest
        try:
            for k, a in enumerate(actions):
                settling = k >= len(actions) - MAX_SETTLE_ACTIONS
                if settling and at_rest(base.cord):
                    break
                # The move is one action here: the cord is judged once it has been carried out.
                base.judge_at_rest = judge and settling
                obs, reward, _, truncated, info = self.env.step(a)
                if truncated:
                    break
        finally:
            base.judge_at_rest = judge
        # Cut off by the time limit during the move, the cord was judged moving: not solved.
        solved = bool(info["is_success"]) and (bool(info["at_rest"]) or not judge)
        return obs, float(reward), solved, bool(truncated), info
