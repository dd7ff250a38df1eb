"""What every goal-conditioned cord environment shares: its arguments, spaces, errors and reward.

The pymunk environments (:mod:`dlo_env.envs.goal_env`) and the learned surrogate ones
(:mod:`latent_model.surrogate_env`) check the same constructor arguments, build the same
observation and action spaces, report the same errors of a shape against its goal and give the
same (batched, HER-ready) reward through :class:`GoalReward`, so an agent moves between them
unchanged.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from dlo_env.cord import MAX_PEGS
from dlo_env.errors import InputError
from dlo_env.shapes import SUCCESS_METRICS, TABLE_HALF, bead_share, error, max_error

REWARD_TYPES = ("dense", "sparse")


def check_goal_args(*, params: object, max_step: object, reward_type: object,
                    success_threshold: object, success_metric: object, judge_at_rest: object,
                    max_pegs: object, render_mode: object, render_modes: list[str]) -> None:
    """Raise a one-line ``ValueError`` naming the first constructor argument out of range."""
    from dlo_env.cord import CordParams

    if params is not None and not isinstance(params, CordParams):
        raise InputError(f"params must be a CordParams or None, got {type(params).__name__}")
    if not (isinstance(max_step, (int, float)) and np.isfinite(max_step) and max_step > 0):
        raise InputError(f"max_step must be a finite number > 0 (metres), got {max_step!r}")
    if reward_type not in REWARD_TYPES:
        raise InputError(f"reward_type must be one of {REWARD_TYPES}, got {reward_type!r}")
    if not (isinstance(success_threshold, (int, float)) and success_threshold > 0):
        raise InputError(f"success_threshold must be a number > 0, got {success_threshold!r}")
    if success_metric not in SUCCESS_METRICS:
        raise InputError(f"success_metric must be one of {tuple(SUCCESS_METRICS)}, got "
                         f"{success_metric!r}")
    if not isinstance(judge_at_rest, (bool, np.bool_)):
        raise InputError(f"judge_at_rest must be True or False, got {judge_at_rest!r}")
    if not (isinstance(max_pegs, (int, np.integer)) and not isinstance(max_pegs, bool)
            and 0 <= max_pegs <= MAX_PEGS):
        raise InputError(f"max_pegs must be an int from 0 to {MAX_PEGS}, got {max_pegs!r}")
    if render_mode is not None and render_mode not in render_modes:
        raise InputError(f"render_mode must be None or one of {render_modes}, got "
                         f"{render_mode!r}")


def goal_spaces(n_points: int, held_ends: int, max_pegs: int = 0
                ) -> tuple[spaces.Box, spaces.Dict]:
    """The action space and the Dict observation space of a cord environment.

    The observation holds the cord's points, then the grippers' positions, then (with pegs)
    ``max_pegs`` centres and their mask; ``achieved_goal`` and ``desired_goal`` are flat shapes.
    """
    h = np.float32(TABLE_HALF)
    action = spaces.Box(-1.0, 1.0, shape=(2 * held_ends,), dtype=np.float32)
    size = 2 * n_points + 2 * held_ends
    low = np.full(size + 3 * max_pegs, -h, dtype=np.float32)
    high = np.full(size + 3 * max_pegs, h, dtype=np.float32)
    low[size + 2 * max_pegs:], high[size + 2 * max_pegs:] = 0.0, 1.0
    observation = spaces.Dict({
        "observation": spaces.Box(low, high, dtype=np.float32),
        "achieved_goal": spaces.Box(-h, h, shape=(2 * n_points,), dtype=np.float32),
        "desired_goal": spaces.Box(-h, h, shape=(2 * n_points,), dtype=np.float32),
    })
    return action, observation


#: The errors an environment reports of a shape against its goal, in ``info``'s order.
METRIC_KEYS = ("error", "max_error", "direction_free_error", "bead_share")


def goal_metrics(shapes: np.ndarray, goals: np.ndarray) -> dict[str, Any]:
    """The errors an environment reports of shapes ``(..., n, 2)`` against goals: the
    :data:`METRIC_KEYS` ``error``, ``max_error``, ``direction_free_error`` and ``bead_share``
    (floats for one shape, arrays of the leading shape for a batch)."""
    goals = np.asarray(goals)
    err = error(shapes, goals)
    free = np.minimum(err, error(shapes, goals[..., ::-1, :]))
    return {
        "error": err,
        "max_error": max_error(shapes, goals),
        "direction_free_error": float(free) if np.ndim(free) == 0 else free,
        "bead_share": bead_share(shapes, goals),
    }


def option_difficulty(options: dict[str, Any], known: tuple[str, ...], difficulty: Any) -> Any:
    """The reset ``options``' rules every cord environment shares: only ``known`` keys,
    ``task`` with ``params`` alone, no ``difficulty`` with a given ``goal``. Returns the
    episode's difficulty: ``options["difficulty"]`` checked, else ``difficulty``.

    Raises:
        ValueError: Naming the option that breaks a rule.
    """
    from dlo_env.tasks import check_difficulty

    unknown = sorted(set(options) - set(known))
    if unknown:
        raise InputError(f"options has unknown keys {unknown}; expected some of {known}")
    if "task" in options and len(set(options) - {"params"}) > 1:
        raise InputError("options['task'] combines only with options['params'] (a task "
                         f"carries its pegs), got {sorted(options)}")
    if "goal" in options and "difficulty" in options:
        raise InputError("options['difficulty'] has no effect when options['goal'] is given")
    if "difficulty" in options:
        return check_difficulty(options["difficulty"], name="options['difficulty']")
    return difficulty


def check_task(task: object, grasp: str, max_step: float) -> Any:
    """``options["task"]`` checked against an environment: a ``dlo_env.tasks.Task`` of its
    grasp and ``max_step`` (a one-line ``ValueError`` naming the option otherwise)."""
    from dlo_env.tasks import Task

    if not isinstance(task, Task):
        raise InputError(f"options['task'] must be a dlo_env.tasks.Task, got "
                         f"{type(task).__name__}")
    if task.grasp != grasp:
        raise InputError(f"options['task'] must have grasp {grasp!r} for this environment, "
                         f"got {task.grasp!r}")
    if task.max_step != max_step:
        raise InputError(f"options['task'] was made with max_step {task.max_step}, this "
                         f"environment uses {max_step}")
    return task


class GoalReward:
    """Gymnasium-Robotics' goal API over batches: the reward, termination and truncation of
    any achieved and desired goals, as ``step`` computes them (hindsight relabelling is
    exact). Needs ``params`` (its ``n_points``), ``reward_type``, ``success_threshold`` and
    ``_distance`` (the success metric's function) on the environment."""

    params: Any
    reward_type: str
    success_threshold: float
    _distance: Any

    def _pairs(self, achieved_goal: np.ndarray, desired_goal: np.ndarray) -> tuple:
        n2 = 2 * self.params.n_points
        a, d = np.asarray(achieved_goal), np.asarray(desired_goal)
        for name, x in (("achieved_goal", a), ("desired_goal", d)):
            if x.ndim < 1 or x.shape[-1] != n2:
                raise InputError(f"{name} must have shape (..., {n2}), got {x.shape}")
        return a.reshape(*a.shape[:-1], n2 // 2, 2), d.reshape(*d.shape[:-1], n2 // 2, 2)

    def compute_reward(
        self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any
    ) -> np.ndarray | float:
        """Reward of reaching ``achieved_goal`` when the goal is ``desired_goal``.

        Works on batches (any leading dimensions), so hindsight relabelling gives exactly the
        rewards ``step`` would have given; ``info`` is not used.

        Args:
            achieved_goal: ``(..., 2n)`` flat shapes, metres.
            desired_goal: ``(..., 2n)`` flat goal shapes.
            info: Ignored (a dict, or a batch of them).

        Returns:
            ``-error`` (dense) or ``-1.0``/``0.0`` (sparse), a float for one pair and an array
            of the leading shape for a batch.
        """
        dist = np.asarray(self._distance(*self._pairs(achieved_goal, desired_goal)))
        if self.reward_type == "dense":
            reward = -dist
        else:
            reward = -(dist > self.success_threshold).astype(np.float64)
        return float(reward) if reward.ndim == 0 else reward

    def compute_terminated(
        self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any
    ) -> np.ndarray | bool:
        """Whether ``achieved_goal`` solves ``desired_goal`` (batched like ``compute_reward``)."""
        pairs = self._pairs(achieved_goal, desired_goal)
        ok = np.asarray(self._distance(*pairs)) <= self.success_threshold
        return bool(ok) if ok.ndim == 0 else ok

    def compute_truncated(
        self, achieved_goal: np.ndarray, desired_goal: np.ndarray, info: Any
    ) -> np.ndarray | bool:
        """Always False: episodes are truncated by the registered time limit only."""
        shape = np.shape(achieved_goal)[:-1]
        return False if shape == () else np.zeros(shape, dtype=bool)
