"""The straight-line reference: move the grasped end straight to where the goal has it."""

from __future__ import annotations

import numpy as np

from dlo_env.errors import InputError
from dlo_env.tasks import GRASP_ENDS, split_move
from planners.episodic_policy import EpisodicPolicy
from planners.moves import actions_through
from planners.observation import CordObservation


class StraightLinePolicy(EpisodicPolicy):
    """Move the held end(s) in one straight line to where the goal has them, then hold still.

    This solves every difficulty-1 task up to the discretisation of the move (the goal was
    made by one straight head move) and is the reference every planner has to beat at higher
    difficulties, where friction makes the result depend on the path. Same interface as
    Stable-Baselines3 models: ``predict(obs, state, episode_start, deterministic)``; a new
    episode is noticed without ``episode_start`` and a vector env's batch gets one line per
    environment (``planners.episodic_policy.EpisodicPolicy``).

    With both ends held (``DLODualEndpoint-v0``) both move at once, each on its own straight
    line, as one move of ``split_move``.

    Args:
        max_step: The environment's ``max_step`` (metres per unit action).
        grasp: ``"head"``, ``"tail"`` or ``"both"``: the end(s) the environment holds.
    """

    def __init__(self, max_step: float = 0.02, grasp: str = "head") -> None:
        if not max_step > 0:
            raise InputError(f"max_step must be > 0, got {max_step!r}")
        if grasp not in GRASP_ENDS:
            raise InputError(f"grasp must be one of {tuple(GRASP_ENDS)}, got {grasp!r}")
        self.max_step = float(max_step)
        self.grasp = grasp
        self.reset()

    def reset(self) -> None:
        """Forget the current episode."""
        self._queue: list[np.ndarray] | None = None

    def _act(self, obs: CordObservation) -> np.ndarray:
        """The next action of the straight move(s) planned at the episode's first step."""
        if self._queue is None:
            if self.grasp == "head":
                self._queue = actions_through(obs.head, obs.goal[:1], self.max_step)
            else:
                index = [0 if end == "head" else -1 for end in GRASP_ENDS[self.grasp]]
                move = (obs.goal[index] - obs.shape[index]).reshape(-1)
                self._queue = list(split_move(move, self.max_step))
        width = 2 * len(GRASP_ENDS[self.grasp])
        return self._queue.pop(0) if self._queue else np.zeros(width, dtype=np.float32)
