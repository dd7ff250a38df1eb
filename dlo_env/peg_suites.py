"""Named suites with pegs on the table: goals made by straight moves with the pegs present.

``pegs-K`` (K = 1, 2, 3) holds tasks of K straight moves, like ``linear-K`` but each with pegs
drawn near its start cord (:func:`dlo_env.tasks.draw_pegs`; task ``i`` of a split has
``1 + i % SUITE_MAX_PEGS`` of them) that stay while the moves run: every goal is one the cord
reaches around the pegs. A task carries its pegs (``Task.pegs``); an environment runs it with
``max_pegs >= SUITE_MAX_PEGS`` (``dlo_bench.evaluation.task_env_kwargs`` gives that).
"""

from __future__ import annotations

import numpy as np

from dlo_env.tasks import SPLIT_SIZES, Task, make_task

#: Suite -> difficulty (straight moves per task).
PEG_SUITES: dict[str, int] = {f"pegs-{k}": k for k in (1, 2, 3)}
#: The most pegs a task of a peg suite has (and the ``max_pegs`` its environment needs).
SUITE_MAX_PEGS = 4
#: Seeds of the peg suites, apart from the linear suites' (100 000 K + 0 or 50 000 + i).
_PEG_SEED = 20_000_000
_SPLIT_OFFSETS = {"train": 0, "test": 50_000}


def peg_suite_seeds(suite: str, split: str) -> np.ndarray:
    """The fixed task seeds of a peg suite's split."""
    if suite not in PEG_SUITES:
        raise ValueError(f"suite must be one of {tuple(PEG_SUITES)}, got {suite!r}")
    if split not in SPLIT_SIZES:
        raise ValueError(f"split must be one of {tuple(SPLIT_SIZES)}, got {split!r}")
    base = _PEG_SEED + 100_000 * PEG_SUITES[suite] + _SPLIT_OFFSETS[split]
    return base + np.arange(SPLIT_SIZES[split])


def peg_count(index: int) -> int:
    """How many pegs task ``index`` of a peg suite's split has (1 to ``SUITE_MAX_PEGS``)."""
    return 1 + int(index) % SUITE_MAX_PEGS


def load_peg_suite(suite: str, split: str = "test", *, grasp: str = "head",
                   limit: int | None = None) -> list[Task]:
    """The tasks of a peg suite's split, in seed order (made on demand).

    Args:
        suite: ``"pegs-1"``, ``"pegs-2"`` or ``"pegs-3"``.
        split: ``"test"`` (50 tasks) or ``"train"`` (200); their seeds never overlap.
        grasp: ``"head"`` for ``DLOEndpoint-v0``, ``"both"`` for ``DLODualEndpoint-v0``.
        limit: Only the first ``limit`` tasks.
    """
    seeds = peg_suite_seeds(suite, split)
    if limit is not None:
        if not (isinstance(limit, int) and not isinstance(limit, bool) and limit >= 0):
            raise ValueError(f"limit must be an int >= 0 or None, got {limit!r}")
        seeds = seeds[:limit]
    return [make_task(int(s), PEG_SUITES[suite], grasp, pegs=peg_count(i))
            for i, s in enumerate(seeds)]
