"""Named suites with pegs on the table: goals made by straight moves with the pegs present.

``pegs-K`` (K = 1, 2, 3) holds tasks of K straight moves, like ``linear-K`` but each with pegs
drawn near its start cord (:func:`dlo_env.tasks.draw_pegs`; task ``i`` of a split has
``1 + i % SUITE_MAX_PEGS`` of them) that stay while the moves run: every goal is one the cord
reaches around the pegs.

``route-K`` (K = 2, 3, 4) keeps, of such tasks of K moves, those that need routing: the goal
cord rests against a peg (within ``ROUTE_CONTACT``) and one straight move of the held end(s) to
the goal's end positions leaves the cord more than ``ROUTE_STRAIGHT_MISS`` from the goal. (No
route-1: a goal one straight move makes is reached by that straight move.) The kept seeds are
found by trying seeds in order; the shipped ``route_seeds.json`` lists them (``python -m
dlo_env.peg_suites --out dlo_env/route_seeds.json`` makes it again) and a test checks it.

A task carries its pegs (``Task.pegs``); an environment runs it with ``max_pegs >=
SUITE_MAX_PEGS`` (``dlo_bench.evaluation.task_env_kwargs`` gives that).
"""

from __future__ import annotations

import argparse
import functools
import json
from pathlib import Path

import numpy as np

from dlo_env.cord import Cord, peg_clearance
from dlo_env.core.atomic import write_text_atomic
from dlo_env.errors import InputError
from dlo_env.shapes import error
from dlo_env.tasks import (
    SPLIT_SIZES,
    SUCCESS_THRESHOLD,
    Task,
    apply_action,
    make_task,
    split_move,
    wait_for_rest,
)

#: Suite -> difficulty (straight moves per task).
PEG_SUITES: dict[str, int] = {f"pegs-{k}": k for k in (1, 2, 3)}
#: The most pegs a task of a peg suite has (and the ``max_pegs`` its environment needs).
SUITE_MAX_PEGS = 4
#: Route suite -> difficulty (straight moves per task).
ROUTE_SUITES: dict[str, int] = {f"route-{k}": k for k in (2, 3, 4)}
#: Every suite with pegs on the table: suite -> difficulty.
PEGGED_SUITES: dict[str, int] = {**PEG_SUITES, **ROUTE_SUITES}
#: A route goal rests within this of a peg's surface (its centre line), metres.
ROUTE_CONTACT = 0.01
#: One straight move to the goal's end positions leaves a route goal farther than this, metres.
ROUTE_STRAIGHT_MISS = SUCCESS_THRESHOLD
#: Seeds of the peg suites, apart from the linear suites' (100 000 K + 0 or 50 000 + i).
_PEG_SEED = 20_000_000
_ROUTE_SEED = 30_000_000
#: Candidate seeds of a route split: (suite, split) -> offset of its seed stream.
_SPLIT_OFFSETS = {"train": 0, "test": 50_000}
#: The shipped seeds of the route suites.
ROUTE_SEEDS_FILE = Path(__file__).with_name("route_seeds.json")
GRASPS = {"head": "endpoint", "both": "dual-endpoint"}


def peg_suite_seeds(suite: str, split: str) -> np.ndarray:
    """The fixed task seeds of a peg suite's split."""
    if suite not in PEG_SUITES:
        raise InputError(f"suite must be one of {tuple(PEG_SUITES)}, got {suite!r}")
    if split not in SPLIT_SIZES:
        raise InputError(f"split must be one of {tuple(SPLIT_SIZES)}, got {split!r}")
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
            raise InputError(f"limit must be an int >= 0 or None, got {limit!r}")
        seeds = seeds[:limit]
    return [make_task(int(s), PEG_SUITES[suite], grasp, pegs=peg_count(i))
            for i, s in enumerate(seeds)]


def straight_miss(task: Task) -> float:
    """``error`` to the goal of the cord at rest after one straight move of the held end(s)
    from the start to the goal's end positions (the pegs present)."""
    cord = Cord(grasp=task.grasp, pegs=task.pegs, peg_radius=task.peg_radius)
    cord.reset(task.start)
    ends = [0] if task.grasp == "head" else [0, -1]
    move = np.concatenate([task.goal[i] - task.start[i] for i in ends]).astype(np.float64)
    for action in split_move(move, task.max_step):
        apply_action(cord, action, task.max_step)
    wait_for_rest(cord, task.max_step)
    return float(error(cord.shape, task.goal))


def needs_routing(task: Task) -> bool:
    """Whether ``task`` is a route task: its goal rests against a peg and one straight move
    of the end(s) misses it by more than ``ROUTE_STRAIGHT_MISS``."""
    if len(task.pegs) == 0:
        return False
    if peg_clearance(task.goal, task.pegs, task.peg_radius) > ROUTE_CONTACT:
        return False
    return straight_miss(task) > ROUTE_STRAIGHT_MISS


def _route_candidate(suite: str, split: str, j: int, grasp: str) -> Task:
    seed = _ROUTE_SEED + 100_000 * ROUTE_SUITES[suite] + _SPLIT_OFFSETS[split] + j
    return make_task(seed, ROUTE_SUITES[suite], grasp, pegs=peg_count(j))


def find_route_seeds(suite: str, split: str, grasp: str = "head",
                     count: int | None = None) -> list[int]:
    """The seeds of a route split, found by trying candidate seeds in order (slow: seconds per
    task kept). ``count`` tasks (None: the split's size)."""
    _check_route(suite, split, grasp)
    count = SPLIT_SIZES[split] if count is None else count
    seeds, j = [], 0
    while len(seeds) < count:
        task = _route_candidate(suite, split, j, grasp)
        if needs_routing(task):
            seeds.append(task.seed)
        j += 1
    return seeds


def _check_route(suite: str, split: str, grasp: str) -> None:
    if suite not in ROUTE_SUITES:
        raise InputError(f"suite must be one of {tuple(ROUTE_SUITES)}, got {suite!r}")
    if split not in SPLIT_SIZES:
        raise InputError(f"split must be one of {tuple(SPLIT_SIZES)}, got {split!r}")
    if grasp not in GRASPS:
        raise InputError(f"grasp must be one of {tuple(GRASPS)}, got {grasp!r}")


@functools.lru_cache(maxsize=1)
def _shipped_seeds() -> dict:
    return json.loads(ROUTE_SEEDS_FILE.read_text())


def route_seeds(suite: str, split: str, grasp: str = "head") -> list[int]:
    """The shipped seeds of a route split (those :func:`find_route_seeds` finds)."""
    _check_route(suite, split, grasp)
    return list(_shipped_seeds()[GRASPS[grasp]][suite][split])


def load_route_suite(suite: str, split: str = "test", *, grasp: str = "head",
                     limit: int | None = None) -> list[Task]:
    """The tasks of a route suite's split, in seed order (made on demand from the shipped
    seeds).

    Args:
        suite: ``"route-2"``, ``"route-3"`` or ``"route-4"``.
        split: ``"test"`` (50 tasks) or ``"train"`` (200).
        grasp: ``"head"`` for ``DLOEndpoint-v0``, ``"both"`` for ``DLODualEndpoint-v0``.
        limit: Only the first ``limit`` tasks.
    """
    seeds = route_seeds(suite, split, grasp)
    if limit is not None:
        if not (isinstance(limit, int) and not isinstance(limit, bool) and limit >= 0):
            raise InputError(f"limit must be an int >= 0 or None, got {limit!r}")
        seeds = seeds[:limit]
    base = _ROUTE_SEED + 100_000 * ROUTE_SUITES[suite] + _SPLIT_OFFSETS[split]
    return [make_task(s, ROUTE_SUITES[suite], grasp, pegs=peg_count(s - base)) for s in seeds]


def main(argv: list[str] | None = None) -> int:
    """Find the seeds of every route split and write them (``--out``; default
    ``runs/route_seeds.json``: the shipped file changes only with ``--out
    dlo_env/route_seeds.json``)."""
    parser = argparse.ArgumentParser(prog="python -m dlo_env.peg_suites",
                                     description=main.__doc__)
    parser.add_argument("--out", default="runs/route_seeds.json")
    args = parser.parse_args(argv)
    seeds = {label: {suite: {split: find_route_seeds(suite, split, grasp)
                             for split in SPLIT_SIZES}
                     for suite in ROUTE_SUITES}
             for grasp, label in GRASPS.items()}
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(args.out, json.dumps(seeds) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
