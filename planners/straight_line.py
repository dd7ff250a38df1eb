"""The straight-line reference: move the grasped end straight to where the goal has it."""

from __future__ import annotations

from typing import Any

import numpy as np

from planners.interfaces import Observation
from planners.moves import actions_through
from planners.observation import read_observation


class StraightLinePolicy:
    """Move the head in one straight line to the goal's head position, then hold still.

    This solves every difficulty-1 task up to the discretisation of the move (the goal was
    made by one straight head move) and is the reference every planner has to beat at higher
    difficulties, where friction makes the result depend on the path. Same interface as
    Stable-Baselines3 models: ``predict(obs, state, episode_start, deterministic)``.

    Args:
        max_step: The environment's ``max_step`` (metres per unit action).
    """

    def __init__(self, max_step: float = 0.02) -> None:
        if not max_step > 0:
            raise ValueError(f"max_step must be > 0, got {max_step!r}")
        self.max_step = float(max_step)
        self.reset()

    def reset(self) -> None:
        """Forget the current episode."""
        self._queue: list[np.ndarray] | None = None

    def predict(
        self,
        observation: Observation,
        state: Any = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        """The next action for one observation (unbatched, or a batch of one)."""
        if episode_start is not None and bool(np.asarray(episode_start).reshape(-1)[0]):
            self.reset()
        n = np.asarray(observation["achieved_goal"]).reshape(-1).size // 2
        obs = read_observation(observation, n)
        if self._queue is None:
            self._queue = actions_through(obs.head, obs.goal[:1], self.max_step)
        action = self._queue.pop(0) if self._queue else np.zeros(2, dtype=np.float32)
        return (action[None] if obs.batched else action), state
