"""Named suites of designed goals: shape a cord from a random start into a drawn curve.

A *designed task* is a random start at rest (as the environments draw it) and a goal made by
:mod:`dlo_env.goals` from a curve family with drawn parameters, pose and angle, relaxed in the
simulator, so the cord can rest in it. Whether a held end can reach it is unknown (no moves
made it): score such tasks direction-free (``gym.make(..., success_metric=
"direction_free_error")``, which :func:`dlo_bench.evaluation.evaluate` sets for these suites).

``shapes-curves`` draws, for each seed, a family and its parameters within the ranges the
default cord rests in (within ``goals.MAX_CHANGE`` of the drawing; measured per grasp, see
docs/tasks.md): arcs, flat S-curves and zigzags with the head held; wide arcs and deep
S-curves with both ends held (zigzags put the ends beyond the grippers' span, spirals and
letters spring open on this cord). A drawing the cord refuses is redrawn from the next
sub-seed, so every task of a split exists.

``shapes-letters`` draws the letters C, J, L, M, S, U, V, W, Z and O (a ring whose ends meet)
in turn (task ``i`` of a split is letter ``i % 10``), each at a drawn width (its ``aspect``),
centre and angle, on the suite's own cord (:data:`LETTERS_CORD`: the default cord springs open
out of letters). The suite names its cord: a task's options carry it and
``dlo_bench.evaluation.task_env_kwargs`` makes the environment on it, so agents are told it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from dlo_env import goals
from dlo_env.cord import CordParams
from dlo_env.errors import InputError
from dlo_env.tasks import SPLIT_SIZES, random_start

#: The cord of ``shapes-letters``: soft, heavy and rough for its length, so it rests in
#: letter-sized bends, and inside ``dlo_env.randomize.DEFAULT_RANGES`` (the several-cords
#: transition model covers it). ``CordParams`` fields; the others are the default cord's.
LETTERS_CORD: dict[str, float] = {"bending_stiffness": 0.003, "friction": 0.6, "mass": 0.3}
#: A letter's width as a share of its drawing's (``goals.letter``'s ``aspect``).
LETTER_ASPECT = (0.8, 1.25)


@dataclass(frozen=True)
class DesignedSuite:
    """What a designed suite draws.

    Attributes:
        families: Grasp -> family (a ``goals.CURVES`` name or a letter of ``goals.LETTERS``)
            -> parameter -> (low, high) (ints: the values to choose from).
        cord: ``CordParams`` fields of the suite's cord ({}: the default cord).
        in_turn: The families in turn by seed (each as often) instead of drawn.
    """

    families: Mapping[str, Mapping[str, Mapping[str, tuple[Any, Any]]]]
    cord: Mapping[str, float] = field(default_factory=dict)
    in_turn: bool = False


_LETTER_FAMILIES = {name: {"aspect": LETTER_ASPECT} for name in goals.LETTERS}

DESIGNED_SUITES: dict[str, DesignedSuite] = {
    "shapes-curves": DesignedSuite({
        "head": {
            "arc": {"span": (1.0, 3.1)},
            "s-curve": {"amplitude": (0.03, 0.06)},
            "zigzag": {"teeth": (2, 3), "amplitude": (0.1, 0.2)},
        },
        "both": {
            "arc": {"span": (2.5, 4.0)},
            "s-curve": {"amplitude": (0.15, 0.25)},
        },
    }),
    "shapes-letters": DesignedSuite({"head": _LETTER_FAMILIES, "both": _LETTER_FAMILIES},
                                    cord=LETTERS_CORD, in_turn=True),
}
#: The goal's centre is drawn within this many metres of the table's centre, on each axis.
CENTER_RANGE = 0.35
#: Seeds of a designed suite's splits start here (away from the linear suites' seeds).
_SEED_BASE = 9_000_000
_SPLIT_OFFSETS = {"train": 0, "test": 50_000}
#: Redraws of a goal the cord refuses before giving up (none needed with these ranges).
MAX_DRAWS = 20
#: Steps of an episode on a designed task (the cord may need long paths to a drawn shape).
DESIGNED_MAX_STEPS = 200


@dataclass(frozen=True, eq=False)
class DesignedTask:
    """A random start and a designed goal; arrays float32 ``(n, 2)``, metres.

    Attributes:
        start: The start shape, at rest.
        goal: The goal shape, at rest.
        family: The curve family (``"arc"``...).
        settings: The family's drawn parameters and the pose (``center``, ``angle``).
        seed: The task's seed.
        grasp: ``"head"`` or ``"both"``.
        params: The suite's cord, or None for the default cord.
    """

    start: np.ndarray
    goal: np.ndarray
    family: str
    settings: dict[str, object]
    seed: int
    grasp: str
    params: CordParams | None = None

    def options(self) -> dict[str, object]:
        """The environment's ``reset`` options of this task (with its cord, if not the
        default)."""
        cord = {} if self.params is None else {"params": self.params}
        return {"start": self.start, "goal": self.goal, **cord}


def _draw(rng: np.random.Generator, ranges: dict[str, object]) -> dict[str, object]:
    out: dict[str, object] = {}
    for name, (low, high) in ranges.items():  # type: ignore[misc]
        out[name] = int(rng.integers(low, high + 1)) if isinstance(low, int) else float(
            rng.uniform(low, high))
    return out


def designed_suite_cord(suite: str) -> CordParams | None:
    """The cord of a designed suite's tasks, or None for the default cord."""
    if suite not in DESIGNED_SUITES:
        raise InputError(f"suite must be one of {tuple(DESIGNED_SUITES)}, got {suite!r}")
    cord = DESIGNED_SUITES[suite].cord
    return replace(CordParams(), **cord) if cord else None


def _goal(family: str, drawn: dict[str, object], **kwargs: Any) -> np.ndarray:
    if family in goals.LETTERS:
        return goals.letter(family, **drawn, **kwargs)  # type: ignore[arg-type]
    return goals.CURVES[family](**drawn, **kwargs)  # type: ignore[operator]


def designed_task(suite: str, seed: int, grasp: str = "head",
                  params: CordParams | None = None) -> DesignedTask:
    """The task of ``suite`` for ``seed``: the same seed gives the same task.

    Args:
        suite, seed, grasp: The task.
        params: The cord (None: the suite's cord, :func:`designed_suite_cord`).

    Raises:
        ValueError: For an unknown suite or a grasp the suite has no families for.
    """
    params = designed_suite_cord(suite) if params is None else params
    spec = DESIGNED_SUITES[suite]
    families = spec.families.get(grasp)
    if not families:
        raise InputError(f"grasp must be one of {tuple(spec.families)} for suite "
                         f"{suite!r}, got {grasp!r}")
    rng = np.random.default_rng(seed)
    start = random_start(int(rng.integers(2**31 - 1)), grasp, params=params)
    names = list(families)
    for _ in range(MAX_DRAWS):
        family = names[int(seed) % len(names) if spec.in_turn else int(rng.integers(len(names)))]
        drawn = _draw(rng, families[family])
        pose = {"center": tuple(float(c) for c in rng.uniform(-CENTER_RANGE, CENTER_RANGE, 2)),
                "angle": float(rng.uniform(-np.pi, np.pi))}
        try:
            goal = _goal(family, drawn, **pose, grasp=grasp, params=params)
        except ValueError:
            continue  # off the table at this pose, or a shape this cord springs out of
        return DesignedTask(start=start, goal=goal, family=family,
                            settings={**drawn, **pose}, seed=int(seed), grasp=grasp,
                            params=params)
    raise RuntimeError(f"no goal of suite {suite!r} for seed {seed} in {MAX_DRAWS} draws")


def designed_suite_seeds(suite: str, split: str) -> np.ndarray:
    """The fixed seeds of a designed suite's split (train 200, test 50)."""
    if suite not in DESIGNED_SUITES:
        raise InputError(f"suite must be one of {tuple(DESIGNED_SUITES)}, got {suite!r}")
    if split not in SPLIT_SIZES:
        raise InputError(f"split must be one of {tuple(SPLIT_SIZES)}, got {split!r}")
    index = list(DESIGNED_SUITES).index(suite)
    return _SEED_BASE + 100_000 * index + _SPLIT_OFFSETS[split] + np.arange(SPLIT_SIZES[split])


def load_designed_suite(suite: str, split: str = "test", *, grasp: str = "head",
                        limit: int | None = None) -> list[DesignedTask]:
    """The tasks of a designed suite's split, in seed order (made on demand, on the suite's
    cord)."""
    seeds = designed_suite_seeds(suite, split)
    if limit is not None:
        if not (isinstance(limit, int) and limit >= 0):
            raise InputError(f"limit must be an int >= 0 or None, got {limit!r}")
        seeds = seeds[:limit]
    return [designed_task(suite, int(s), grasp) for s in seeds]
