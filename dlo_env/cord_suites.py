"""Named suites on cords that differ: the linear tasks, made on cords the agent is not told.

``cords-K`` (K = 1, 2, 3) holds tasks of K straight moves, like ``linear-K`` and from its
seeds, each made on its own cord: test task ``i`` on ``dlo_env.randomize.TEST_CORDS[i % 6]``
(cords no cord-conditioned model trains near), train task ``i`` on a cord drawn from
``DEFAULT_RANGES`` away from the test cords. An episode resets with ``{"task": task,
"params": cord}``; the observation does not hold the cord (``info["params"]`` does), so an
agent learns it only from how the cord moves.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dlo_env.cord import CordParams
from dlo_env.errors import InputError
from dlo_env.randomize import TEST_CORDS, draw_train_cord, test_cord
from dlo_env.tasks import SPLIT_SIZES, Task, make_task, suite_seeds

#: Suite -> difficulty (straight moves per task).
CORD_SUITES: dict[str, int] = {f"cords-{k}": k for k in (1, 2, 3)}
#: Seed of the train split's cord draws (one generator per task seed).
_CORD_SEED = 7_000_000


@dataclass(frozen=True, eq=False)
class CordTask:
    """A task made on its own cord.

    Attributes:
        task: The task (start and goal at rest on ``params``).
        params: The cord it was made on, and the episode's cord.
        cord: Index into ``TEST_CORDS`` (test split), -1 for a drawn cord (train split).
    """

    task: Task
    params: CordParams
    cord: int = -1

    def options(self) -> dict[str, object]:
        """The environment's ``reset`` options of this task."""
        return {"task": self.task, "params": self.params}


def _check(suite: str, split: str) -> None:
    if suite not in CORD_SUITES:
        raise InputError(f"suite must be one of {tuple(CORD_SUITES)}, got {suite!r}")
    if split not in SPLIT_SIZES:
        raise InputError(f"split must be one of {tuple(SPLIT_SIZES)}, got {split!r}")


def test_cord_index(index: int) -> int:
    """The index into ``TEST_CORDS`` of test task ``index`` of a cord suite (they take turns)."""
    return int(index) % len(TEST_CORDS)


def train_cord(seed: int, base: CordParams | None = None) -> CordParams:
    """The cord of a train task: drawn from ``DEFAULT_RANGES`` with a generator seeded by
    ``seed``, redrawn while it lies near a test cord."""
    return draw_train_cord(base if base is not None else CordParams(),
                           np.random.default_rng(_CORD_SEED + int(seed)))


def cord_task(suite: str, split: str, index: int, grasp: str = "head") -> CordTask:
    """Task ``index`` of a cord suite's split."""
    _check(suite, split)
    seeds = suite_seeds(f"linear-{CORD_SUITES[suite]}", split)
    if not (isinstance(index, (int, np.integer)) and not isinstance(index, bool)
            and 0 <= index < len(seeds)):
        raise InputError(f"index must be an int in 0..{len(seeds) - 1}, got {index!r}")
    seed = int(seeds[index])
    if split == "test":
        cord = test_cord_index(index)
        params = test_cord(cord, CordParams())
    else:
        cord, params = -1, train_cord(seed)
    task = make_task(seed, CORD_SUITES[suite], grasp, params=params)
    return CordTask(task=task, params=params, cord=cord)


def load_cord_suite(suite: str, split: str = "test", *, grasp: str = "head",
                    limit: int | None = None) -> list[CordTask]:
    """The tasks of a cord suite's split, in seed order (made on demand).

    Args:
        suite: ``"cords-1"``, ``"cords-2"`` or ``"cords-3"``.
        split: ``"test"`` (50 tasks on the six test cords in turn) or ``"train"`` (200 on drawn
            cords).
        grasp: ``"head"`` for ``DLOEndpoint-v0``, ``"both"`` for ``DLODualEndpoint-v0``.
        limit: Only the first ``limit`` tasks.
    """
    _check(suite, split)
    count = SPLIT_SIZES[split]
    if limit is not None:
        if not (isinstance(limit, int) and not isinstance(limit, bool) and limit >= 0):
            raise InputError(f"limit must be an int >= 0 or None, got {limit!r}")
        count = min(count, limit)
    return [cord_task(suite, split, i, grasp) for i in range(count)]

