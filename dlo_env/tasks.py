"""Tasks: a start shape at rest, a goal reachable from it, and the actions that reach it.

A goal is made in the simulator, never drawn: from the start, ``difficulty`` random straight
moves of the grasped end(s) (uniform direction, length U(5 cm, 30 cm), each end its own move
when both are held) run through :func:`apply_action`, the very step primitive of the
environments: each move is split into ``ceil(length / max_step)`` equal actions, and zero
actions follow the last move until the cord is at rest. Because ``Cord.reset`` rebuilds the
simulation from scratch, replaying ``reference_actions`` through ``env.step`` from the reset
state reproduces the goal bitwise (with ``judge_at_rest=False``; judged at rest, an episode
may end solved a few actions earlier): they are an oracle and a source of demonstrations.

Named suites (``linear-1`` to ``linear-5``, and the long horizons ``linear-8`` and
``linear-10``: difficulty K) fix the seeds of a train and a test split so results are
comparable; ``suite_max_steps`` gives their episode lengths. Task lists are saved as ``.npz``
data files.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dlo_env.cord import (
    LINK_RADIUS,
    PEG_RADIUS,
    Cord,
    CordParams,
    Grasp,
    check_not_crossing,
    check_pegs,
    peg_clearance,
)
from dlo_env.core.atomic import atomic_path
from dlo_env.dataset.npz_file import open_npz
from dlo_env.errors import InputError
from dlo_env.shapes import (
    TABLE_HALF,
    error,
    is_cord_like,
    on_table,
    random_cord_shape,
    segment_lengths,
    validate_shape,
)

#: Range of the length of one random straight move of a grasped end, metres.
MOVE_LENGTH = (0.05, 0.30)
#: Largest number of straight moves in a task.
MAX_DIFFICULTY = 10
#: Gripper displacement of an action of 1.0 on one axis, metres (the environments' default).
DEFAULT_MAX_STEP = 0.02
#: A task is solved when ``error(cord, goal)`` is at most this, metres.
SUCCESS_THRESHOLD = 0.02
#: Every point slower than this (m/s) means the cord is at rest.
REST_SPEED = 1e-3
#: At most this many zero actions after the last move wait for the cord to come to rest.
MAX_SETTLE_ACTIONS = 10
#: The environments test whether a moving cord would come to rest within the success threshold
#: when its error is at most the threshold plus this, metres. A cord moves less than this while
#: coming to rest after any action (at most 0.7 cm in mean point distance after full-speed random
#: actions, ``tests/dlo_env/test_judged_at_rest.py``); a larger margin only costs time.
REST_CHECK_MARGIN = 0.01
#: Move targets keep this distance from the table edge, metres (the cord is not pressed on it).
TARGET_MARGIN = 0.1
#: With both ends held, head and tail stay this much closer than ``max_span * length``, metres.
SPAN_MARGIN = 0.02
#: A start cord's centre line keeps at least this far from every peg's surface, metres.
PEG_CLEARANCE = 0.02
#: A drawn peg's surface lies at most this far from the start cord, so moves meet it, metres.
PEG_NEAR = 0.15
#: Drawn pegs leave at least this gap between their surfaces (a cord passes between), metres.
PEG_GAP = 0.04
#: A goal's segments stay within this share of their rest length: both grippers can hold a cord
#: taut round pegs, stretched (up to 11 % in tasks drawn before this rule; past 5 %
#: ``reset(options={"goal": ...})`` refuses a shape), which the cord does not rest in; such a
#: goal is redrawn. Goals without pegs stay within 0.1 %.
GOAL_STRETCH = 0.02
#: Version of the ``.npz`` task file layout written by :func:`save_tasks` (2 adds the pegs;
#: files of version 1, without pegs, stay readable).
FORMAT_VERSION = 2

#: The ends each grasp holds, in the order of their action components.
GRASP_ENDS: dict[str, tuple[str, ...]] = {
    "head": ("head",),
    "tail": ("tail",),
    "both": ("head", "tail"),
}
#: Named suites: name -> difficulty (straight moves from start to goal); linear-8 and
#: linear-10 are the long horizons.
SUITES = {f"linear-{k}": k for k in (1, 2, 3, 4, 5, 8, 10)}
#: Steps of an episode on a suite's task: the registered 100, or 20 per move for long horizons
#: (a move takes 9 actions on average; linear-10's reference actions take up to about 120).
STEPS_PER_MOVE = 20
#: Tasks per split of every suite.
SPLIT_SIZES = {"train": 200, "test": 50}
_SPLIT_OFFSETS = {"train": 0, "test": 50_000}


def action_dim(grasp: str) -> int:
    """Length of an action for a grasp: two components (dx, dy) per held end."""
    if grasp not in GRASP_ENDS:
        raise InputError(f"grasp must be one of {tuple(GRASP_ENDS)}, got {grasp!r}")
    return 2 * len(GRASP_ENDS[grasp])


@dataclass(frozen=True, eq=False, repr=False)
class Task:
    """One manipulation task; arrays are float32, distances metres.

    Attributes:
        start: ``(n, 2)`` start shape (at rest when generated).
        goal: ``(n, 2)`` goal shape, the result of ``reference_actions`` from ``start``.
        reference_actions: ``(T, action_dim)`` environment actions in ``[-1, 1]`` that reach the
            goal bitwise from a freshly reset cord.
        difficulty: Number of straight moves, 1 to ``MAX_DIFFICULTY``.
        seed: The seed :func:`make_task` generated the task from (``-1`` if unknown).
        grasp: Held ends, ``"head"``, ``"tail"`` or ``"both"``.
        moves: ``(difficulty, action_dim)`` displacement of each straight move, metres (head
            dx, dy then tail dx, dy when both ends are held).
        max_step: Gripper displacement of an action of 1.0, metres.
        pegs: ``(k, 2)`` centres of the pegs on the table during the task, metres (``(0, 2)``:
            none).
        peg_radius: Their radius, metres.
    """

    start: np.ndarray
    goal: np.ndarray
    reference_actions: np.ndarray
    difficulty: int
    seed: int
    grasp: str
    moves: np.ndarray
    max_step: float = DEFAULT_MAX_STEP
    pegs: np.ndarray | None = None
    peg_radius: float = PEG_RADIUS

    def __post_init__(self) -> None:
        dim = action_dim(self.grasp)
        object.__setattr__(self, "pegs", check_pegs(self.pegs, "Task.pegs").astype(np.float32))
        if not (isinstance(self.peg_radius, (float, int, np.floating))
                and not isinstance(self.peg_radius, bool)
                and 0 < self.peg_radius < TABLE_HALF):
            raise InputError(f"Task.peg_radius must be a number of metres in (0, {TABLE_HALF}), "
                             f"got {self.peg_radius!r}")
        object.__setattr__(self, "peg_radius", float(self.peg_radius))
        for name in ("start", "goal", "reference_actions", "moves"):
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=np.float32))
        if self.start.ndim != 2 or self.start.shape[1] != 2 or self.goal.shape != self.start.shape:
            raise InputError(
                "Task.start and Task.goal must both have shape (n, 2), got "
                f"{self.start.shape} and {self.goal.shape}"
            )
        check_difficulty(self.difficulty, name="Task.difficulty")
        actions = self.reference_actions
        if actions.ndim != 2 or actions.shape[1] != dim:
            raise InputError(
                f"Task.reference_actions must have shape (T, {dim}) for grasp {self.grasp!r}, "
                f"got {actions.shape}"
            )
        if not (np.isfinite(actions).all() and (np.abs(actions) <= 1.0).all()):
            raise InputError("Task.reference_actions must be finite and within [-1, 1]")
        if self.moves.shape != (self.difficulty, dim):
            raise InputError(
                f"Task.moves must have shape ({self.difficulty}, {dim}), got {self.moves.shape}"
            )
        if not (isinstance(self.max_step, (float, int)) and self.max_step > 0):
            raise InputError(f"Task.max_step must be a number > 0, got {self.max_step!r}")
        object.__setattr__(self, "difficulty", int(self.difficulty))
        object.__setattr__(self, "seed", int(self.seed))
        object.__setattr__(self, "max_step", float(self.max_step))

    @property
    def action_dim(self) -> int:
        """Length of one action."""
        return action_dim(self.grasp)

    def options(self) -> dict[str, object]:
        """The environment's ``reset`` options of this task (its pegs come with it)."""
        return {"task": self}

    def __repr__(self) -> str:
        return (
            f"Task(grasp={self.grasp!r}, difficulty={self.difficulty}, seed={self.seed}, "
            f"n_points={len(self.start)}, reference_actions={len(self.reference_actions)}, "
            f"max_step={self.max_step}" + (f", pegs={len(self.pegs)})" if len(self.pegs) else ")")
        )


def check_difficulty(difficulty: object, name: str = "difficulty") -> int:
    """Return ``difficulty`` as an int, or raise ``ValueError`` unless it is an int in 1-10."""
    ok = isinstance(difficulty, (int, np.integer)) and not isinstance(difficulty, bool)
    if not ok or not 1 <= int(difficulty) <= MAX_DIFFICULTY:
        raise InputError(f"{name} must be an int from 1 to {MAX_DIFFICULTY}, got {difficulty!r}")
    return int(difficulty)


def apply_action(cord: Cord, action: np.ndarray, max_step: float) -> None:
    """The environments' step primitive: one ``Cord.move`` of the held ends.

    Each component is clipped to ``[-1, 1]`` and scaled by ``max_step``; the components are
    (dx, dy) of the head, then of the tail, for the ends ``cord.grasp`` holds. The move lasts
    one control period when no end moves farther than ``max_speed * dt`` (0.02 m by default),
    longer otherwise (a full diagonal action at the default settings takes two).

    Args:
        cord: A reset cord holding the ends ``GRASP_ENDS[cord.grasp]``.
        action: ``(2 * ends,)`` finite action (validated by the caller).
        max_step: Displacement of an action of 1.0, metres.
    """
    cord.move(**action_moves(cord.grasp, action, max_step))


def action_moves(grasp: str, action: np.ndarray, max_step: float) -> dict[str, np.ndarray]:
    """The displacements ``apply_action`` gives ``Cord.move`` (its ``head`` and ``tail``
    keywords) for ``action`` on a cord holding the ends of ``grasp``."""
    # minimum/maximum: np.clip's arithmetic without its call overhead (every environment step).
    d = np.minimum(np.maximum(action, -1.0), 1.0).astype(np.float64) * max_step
    if grasp == "both":
        return {"head": d[0:2], "tail": d[2:4]}
    if grasp == "head":
        return {"head": d}
    return {"tail": d}


def split_move(displacement: np.ndarray, max_step: float) -> np.ndarray:
    """Equal actions that carry out one straight move, float32 ``(k, len(displacement))``.

    ``k = ceil(longest end displacement / max_step)`` (at least 1), so every action moves each
    end by at most ``max_step`` and lies in ``[-1, 1]``.
    """
    d = np.asarray(displacement, dtype=np.float64).reshape(-1)
    longest = float(np.linalg.norm(d.reshape(-1, 2), axis=1).max())
    k = max(1, math.ceil(longest / max_step - 1e-9))
    step = np.clip(d / (k * max_step), -1.0, 1.0).astype(np.float32)
    return np.tile(step, (k, 1))


def _rest(cord: Cord) -> bool:
    return cord.max_point_speed() < REST_SPEED


def at_rest(cord: Cord) -> bool:
    """Whether every point of ``cord`` is slower than ``REST_SPEED`` (``wait_for_rest``'s test)."""
    return _rest(cord)


def wait_for_rest(cord: Cord, max_step: float = DEFAULT_MAX_STEP) -> int:
    """Zero actions until the cord is at rest, at most ``MAX_SETTLE_ACTIONS``: the rule that
    ends every task goal and every recorded transition.

    Returns:
        The number of zero actions taken (``MAX_SETTLE_ACTIONS`` and still moving is possible).
    """
    zero = np.zeros(action_dim(cord.grasp), dtype=np.float32)
    for taken in range(MAX_SETTLE_ACTIONS):
        if _rest(cord):
            return taken
        apply_action(cord, zero, max_step)
    return MAX_SETTLE_ACTIONS


def random_start(
    seed: int | np.random.Generator, grasp: Grasp = "head", *, params: CordParams | None = None,
    cord: Cord | None = None, draw: Callable[..., np.ndarray] = random_cord_shape,
) -> np.ndarray:
    """A random cord-like start shape at rest: a shape from ``draw`` settled in the simulator.

    The shape settles with the grippers of ``grasp`` holding its ends (bent joints relax until
    friction holds them). With both ends held, head and tail end up closer than
    ``max_span * length - SPAN_MARGIN``.

    Args:
        seed: Seed or generator.
        grasp: Held ends while settling, ``"head"``, ``"tail"`` or ``"both"``.
        params: Cord parameters (default cord if None).
        cord: Settle on this cord (its params and grasp are used; it is left in some
            simulated state, so reset it before use) instead of a new one.
        draw: The shape drawer, called as ``draw(rng, n_points=..., length=...)``
            (``random_cord_shape``, or :func:`dlo_env.shapes.wide_cord_shape` or
            :func:`dlo_env.shapes.wavy_cord_shape` for more strongly bent starts).

    Returns:
        float32 ``(n, 2)``.
    """
    if cord is None:
        action_dim(grasp)
        cord = Cord(params, grasp=grasp)
    return _random_start(np.random.default_rng(seed), cord, draw)


def _random_start(rng: np.random.Generator, cord: Cord,
                  draw: Callable[..., np.ndarray] = random_cord_shape) -> np.ndarray:
    p = cord.params
    span = p.max_span * p.length - SPAN_MARGIN
    for _ in range(1000):
        shape = draw(rng, n_points=p.n_points, length=p.length)
        if cord.grasp == "both" and np.linalg.norm(shape[-1] - shape[0]) >= span:
            continue
        pegs = cord.pegs
        if len(pegs) and peg_clearance(shape, pegs, cord.peg_radius) < PEG_CLEARANCE:
            continue
        cord.reset(shape)
        cord.settle(tolerance=REST_SPEED, max_time=3.0)
        settled = cord.shape
        # A strongly bent shape can sweep far while it relaxes and end up pressed against the
        # rim (still on the table, which the check guards): not a valid start.
        if not _rest(cord) or not is_cord_like(settled) or not on_table(settled):
            continue
        if len(pegs) and peg_clearance(settled, pegs, cord.peg_radius) < PEG_CLEARANCE:
            continue
        if cord.grasp == "both" and np.linalg.norm(settled[-1] - settled[0]) >= span:
            continue
        return settled
    raise RuntimeError("could not draw a start shape that settles")  # pragma: no cover


def draw_pegs(rng: np.random.Generator, count: int, shape: np.ndarray,
              peg_radius: float = PEG_RADIUS) -> np.ndarray:
    """``count`` pegs near the cord ``shape``: each surface ``PEG_CLEARANCE`` to ``PEG_NEAR``
    from its centre line, ``PEG_GAP`` from the other pegs, inside the move targets' area.

    Returns:
        float32 ``(count, 2)`` peg centres (as a task stores them).
    """
    pts = np.asarray(shape, dtype=np.float64)
    lim = TABLE_HALF - TARGET_MARGIN
    pegs: list[np.ndarray] = []
    for _ in range(1000 * max(count, 1)):
        if len(pegs) == count:
            break
        i = int(rng.integers(len(pts) - 1))
        anchor = pts[i] + rng.uniform() * (pts[i + 1] - pts[i])
        angle = rng.uniform(-np.pi, np.pi)
        dist = peg_radius + LINK_RADIUS + rng.uniform(PEG_CLEARANCE, PEG_NEAR)
        centre = (anchor + dist * np.array([math.cos(angle), math.sin(angle)])).astype(np.float32)
        if (np.abs(centre) > lim).any():
            continue
        if peg_clearance(pts, centre[None], peg_radius) < PEG_CLEARANCE:
            continue
        if any(np.linalg.norm(centre - q) < 2 * peg_radius + PEG_GAP for q in pegs):
            continue
        pegs.append(centre)
    if len(pegs) < count:
        raise InputError(f"could not place {count} pegs near the cord (each {PEG_CLEARANCE} to "
                         f"{PEG_NEAR} m from it, {PEG_GAP} m apart): ask for fewer pegs")
    return np.asarray(pegs, dtype=np.float32).reshape(-1, 2)


def _random_move(
    rng: np.random.Generator, positions: dict[str, np.ndarray], cord: Cord
) -> np.ndarray | None:
    """One displacement per held end whose targets stay on the table (and within the span)."""
    p = cord.params
    lim = TABLE_HALF - max(TARGET_MARGIN, p.rim_margin)
    ends = GRASP_ENDS[cord.grasp]
    for _ in range(200):
        angle = rng.uniform(-np.pi, np.pi, size=len(ends))
        length = rng.uniform(*MOVE_LENGTH, size=len(ends))
        d = length[:, None] * np.stack([np.cos(angle), np.sin(angle)], axis=1)
        targets = np.stack([positions[e] for e in ends]) + d
        if (np.abs(targets) > lim).any():
            continue
        if len(ends) == 2 and np.linalg.norm(targets[1] - targets[0]) >= (
            p.max_span * p.length - SPAN_MARGIN
        ):
            continue
        return d.reshape(-1)
    return None


def make_task(
    seed: int,
    difficulty: int = 1,
    grasp: Grasp = "head",
    *,
    params: CordParams | None = None,
    max_step: float = DEFAULT_MAX_STEP,
    start: np.ndarray | None = None,
    min_error: float = SUCCESS_THRESHOLD,
    pegs: np.ndarray | int | None = None,
    peg_radius: float = PEG_RADIUS,
) -> Task:
    """Generate a task: a start at rest and a goal ``difficulty`` straight moves away.

    Args:
        seed: Seed of everything random in the task; the same seed gives the same task.
        difficulty: Number of straight moves, 1-10.
        grasp: Held ends, ``"head"``, ``"tail"`` or ``"both"``.
        params: Cord parameters (default cord if None).
        max_step: Gripper displacement of an action of 1.0, metres.
        start: Use this start shape (as given, not settled) instead of a random one.
        min_error: The goal is redrawn until ``error(start, goal) > min_error``, so a new task
            is never solved at the start (and until every goal point is on the table and
            every segment within ``GOAL_STRETCH`` of its rest length).
        pegs: Pegs on the table while the moves run: ``(k, 2)`` centres (a drawn start keeps
            ``PEG_CLEARANCE`` from them; a given one must not cross them), or a count drawn
            near the start (:func:`draw_pegs`), or None: none.
        peg_radius: Radius of the pegs, metres.

    Returns:
        The task; its ``reference_actions`` replayed from ``start`` reproduce ``goal`` bitwise.
    """
    difficulty = check_difficulty(difficulty)
    dim = action_dim(grasp)
    if not max_step > 0:
        raise InputError(f"max_step must be > 0, got {max_step!r}")
    count = 0
    if isinstance(pegs, (int, np.integer)) and not isinstance(pegs, bool):
        if pegs < 0:
            raise InputError(f"pegs must be a count >= 0 or (k, 2) centres, got {pegs!r}")
        count, fixed = int(pegs), None
    else:  # float32, as the task stores them: the replay sees the very same pegs
        fixed = check_pegs(pegs).astype(np.float32)
    rng = np.random.default_rng(seed)
    cord = Cord(params, grasp=grasp, pegs=fixed, peg_radius=peg_radius)
    p = cord.params
    if start is None:
        # The cord re-projects every segment to its exact rest length: a drawn start is the
        # shape the simulator actually holds after ``reset``, so an episode begins exactly there.
        cord.reset(_random_start(rng, cord))
        start = cord.shape
    else:
        start = validate_shape(start, n_points=p.n_points, length=p.length, name="start")
        if fixed is not None:
            check_not_crossing(start, fixed, peg_radius, "start: the cord")
    if count:
        cord.set_pegs(draw_pegs(rng, count, start, peg_radius))
    for _ in range(100):
        cord.reset(start)  # fresh, exactly as env.reset does: the replay is bitwise
        actions, moves = [], []
        for _ in range(difficulty):
            move = _random_move(rng, cord.gripper_positions(), cord)
            if move is None:
                raise InputError("start: no straight move of a grasped end stays on the table")
            steps = split_move(move, max_step)
            for action in steps:
                apply_action(cord, action, max_step)
            actions.append(steps)
            moves.append(steps.astype(np.float64).sum(axis=0) * max_step)
        actions.append(np.zeros((wait_for_rest(cord, max_step), dim), dtype=np.float32))
        goal = cord.shape
        stretch = float(np.abs(segment_lengths(goal) / p.segment - 1.0).max())
        if error(start, goal) > min_error and on_table(goal) and stretch <= GOAL_STRETCH:
            return Task(
                start=start,
                goal=goal,
                reference_actions=np.concatenate(actions),
                difficulty=difficulty,
                seed=int(seed),
                grasp=grasp,
                moves=np.array(moves),
                max_step=max_step,
                pegs=cord.pegs.astype(np.float32),
                peg_radius=peg_radius,
            )
    raise RuntimeError(f"no goal farther than min_error={min_error} m from the start, on the "
                       f"table and stretched at most GOAL_STRETCH={GOAL_STRETCH} in 100 draws")


def difficulty_max_steps(difficulty: int) -> int:
    """The episode length for tasks of ``difficulty`` straight moves:
    ``max(100, STEPS_PER_MOVE * K)`` (the registered 100 up to difficulty 5)."""
    return max(100, STEPS_PER_MOVE * check_difficulty(difficulty))


def suite_max_steps(name: str) -> int:
    """The episode length for a named suite's tasks (``difficulty_max_steps`` of its K)."""
    if name not in SUITES:
        raise InputError(f"suite name must be one of {tuple(SUITES)}, got {name!r}")
    return difficulty_max_steps(SUITES[name])


def suite_seeds(name: str, split: str) -> np.ndarray:
    """The fixed task seeds of a named suite's split."""
    if name not in SUITES:
        raise InputError(f"suite name must be one of {tuple(SUITES)}, got {name!r}")
    if split not in SPLIT_SIZES:
        raise InputError(f"split must be one of {tuple(SPLIT_SIZES)}, got {split!r}")
    base = 100_000 * SUITES[name] + _SPLIT_OFFSETS[split]
    return base + np.arange(SPLIT_SIZES[split])


def load_suite(
    name: str, split: str = "test", *, grasp: Grasp = "head", limit: int | None = None
) -> list[Task]:
    """The tasks of a named suite (generated from its fixed seeds on the default cord).

    Args:
        name: ``"linear-K"``, K = 1..5, 8 or 10 (difficulty K).
        split: ``"train"`` (200 tasks) or ``"test"`` (50 tasks); their seeds never overlap.
        grasp: ``"head"`` for ``DLOEndpoint-v0``, ``"both"`` for ``DLODualEndpoint-v0``.
        limit: Only the first ``limit`` tasks.

    Returns:
        The tasks, in seed order.
    """
    seeds = suite_seeds(name, split)
    if limit is not None:
        if not (isinstance(limit, int) and limit >= 0):
            raise InputError(f"limit must be an int >= 0 or None, got {limit!r}")
        seeds = seeds[:limit]
    return [make_task(int(s), SUITES[name], grasp) for s in seeds]


def save_tasks(path: str | os.PathLike, tasks: list[Task]) -> None:
    """Write tasks to an ``.npz`` data file (atomically: a temp file, then ``os.replace``).

    All tasks must share the grasp and the number of points.
    """
    if not tasks or not all(isinstance(t, Task) for t in tasks):
        raise InputError("tasks must be a non-empty list of Task")
    if len({(t.grasp, t.start.shape) for t in tasks}) != 1:
        raise InputError("tasks must all have the same grasp and number of points")
    arrays = {
        "format_version": np.array(FORMAT_VERSION),
        "start": np.stack([t.start for t in tasks]),
        "goal": np.stack([t.goal for t in tasks]),
        "reference_actions": np.concatenate([t.reference_actions for t in tasks]),
        "action_counts": np.array([len(t.reference_actions) for t in tasks], dtype=np.int64),
        "moves": np.concatenate([t.moves for t in tasks]),
        "difficulty": np.array([t.difficulty for t in tasks], dtype=np.int64),
        "seed": np.array([t.seed for t in tasks], dtype=np.int64),
        "grasp": np.array(tasks[0].grasp),
        "max_step": np.array([t.max_step for t in tasks], dtype=np.float64),
        "pegs": np.concatenate([t.pegs for t in tasks]).reshape(-1, 2),
        "peg_counts": np.array([len(t.pegs) for t in tasks], dtype=np.int64),
        "peg_radius": np.array([t.peg_radius for t in tasks], dtype=np.float64),
    }
    path = Path(path)
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        np.savez_compressed(f, **arrays)


def load_tasks(path: str | os.PathLike) -> list[Task]:
    """Read tasks written by :func:`save_tasks` (data only: no pickle is ever loaded)."""
    keys = ("format_version", "start", "goal", "reference_actions", "action_counts", "moves",
            "difficulty", "seed", "grasp", "max_step")
    data = open_npz(path, f"path {str(path)!r}", "dlo task file")
    with data:
        missing = [k for k in keys if k not in data.files]
        if missing:
            raise InputError(f"path {str(path)!r} is not a dlo task file: missing {missing}")
        arrays = {k: data[k] for k in keys}
        version = int(arrays["format_version"])
        if version not in (1, FORMAT_VERSION):
            raise InputError(
                f"path {str(path)!r} has task format version {version}, this dlo reads "
                f"versions 1 to {FORMAT_VERSION}"
            )
        peg_keys = ("pegs", "peg_counts", "peg_radius")
        if version >= 2:
            missing = [k for k in peg_keys if k not in data.files]
            if missing:
                raise InputError(f"path {str(path)!r} is not a dlo task file: missing {missing}")
            arrays.update({k: data[k] for k in peg_keys})
    counts, difficulty = arrays["action_counts"], arrays["difficulty"]
    action_ends = np.concatenate([[0], np.cumsum(counts)])
    move_ends = np.concatenate([[0], np.cumsum(difficulty)])
    if action_ends[-1] != len(arrays["reference_actions"]) or move_ends[-1] != len(
        arrays["moves"]
    ):
        raise InputError(f"path {str(path)!r} is corrupt: action or move counts do not add up")
    grasp = str(arrays["grasp"])
    size = len(counts)
    peg_counts = arrays.get("peg_counts", np.zeros(size, dtype=np.int64))
    peg_ends = np.concatenate([[0], np.cumsum(peg_counts)])
    pegs = arrays.get("pegs", np.zeros((0, 2), dtype=np.float32))
    radius = arrays.get("peg_radius", np.full(size, PEG_RADIUS))
    if peg_ends[-1] != len(pegs) or len(peg_counts) != size or len(radius) != size:
        raise InputError(f"path {str(path)!r} is corrupt: peg counts do not add up")
    return [
        Task(
            start=arrays["start"][i],
            goal=arrays["goal"][i],
            reference_actions=arrays["reference_actions"][action_ends[i] : action_ends[i + 1]],
            difficulty=int(difficulty[i]),
            seed=int(arrays["seed"][i]),
            grasp=grasp,
            moves=arrays["moves"][move_ends[i] : move_ends[i + 1]],
            max_step=float(arrays["max_step"][i]),
            pegs=pegs[peg_ends[i] : peg_ends[i + 1]],
            peg_radius=float(radius[i]),
        )
        for i in range(size)
    ]
