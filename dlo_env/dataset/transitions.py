"""One-move transitions: a cord at rest, one straight move of the held end(s), the cord at rest.

A transition is carried out exactly as tasks do it: the displacement is split into equal
actions (:func:`dlo_env.tasks.split_move`) run through :func:`dlo_env.tasks.apply_action`, then
zero actions follow until the cord is at rest (:func:`dlo_env.tasks.wait_for_rest`). Chaining
transitions therefore reproduces task goals.

One *episode* draws a grasp (head, tail or both), a random start at rest
(:func:`dlo_env.tasks.random_start`) and applies ``moves_per_episode`` moves to the same cord, so
the starts of later moves are shapes reached after one to four earlier moves. Each end's move
has a length uniform in ``[min_move, max_move]`` and a direction that is uniform, or aims at the
cord's middle (``push_fraction``: pushes buckle the cord and fold it onto itself), or at the
nearest table edge (``rim_fraction``: moves that press the cord on the rim); half the lengths
are drawn log-uniformly so short corrective moves are well represented.

With ``max_pegs`` > 0, each episode places 0 to ``max_pegs`` pegs near its start
(:func:`dlo_env.tasks.draw_pegs`), and its moves run around them.

The ``.npz`` layout (format ``dlo-transitions``, version 3; no pickles; version 1 lacked
``params``, version 2 the pegs):

================ ============== ==============================================================
array            dtype, shape   meaning
================ ============== ==============================================================
``start``        f4 (T, n, 2)   shape at rest before the move, metres
``next``         f4 (T, n, 2)   shape at rest after the move
``grasp``        i1 (T,)        ends moved: 0 head, 1 tail, 2 both (``GRASP_NAMES``)
``displacement`` f4 (T, 2, 2)   commanded displacement of [head, tail]; zero for an end not held
``moved``        f4 (T, 2, 2)   where the grippers really went (targets clipped to the table)
``episode``      i8 (T,)        episode of the move; moves of one episode follow each other
``step``         i8 (T,)        earlier moves in the episode (0: from a random start)
``settle``       i1 (T,)        zero actions it took to come to rest
``at_rest``      ?  (T,)        whether ``next`` is at rest (else ``MAX_SETTLE_ACTIONS`` ran out)
``params``       f4 (T, 4)      the cord of the move: ``PARAM_COLUMNS`` (length m, bending
                                stiffness N m^2, friction, mass kg); version 2 on
``pegs``         f4 (T, p, 2)   centres of the pegs on the table, metres, in the first
                                ``peg_count`` of ``p`` slots (zeros after); version 3 on
``peg_count``    i1 (T,)        pegs on the table during the move (0: none)
``metadata``     str ()         JSON: format, version, cord, settings, counts, times
================ ============== ==============================================================

Example:
    >>> data = collect_transitions("runs/transitions.npz", 20_000, workers=2)
    >>> data = load_transitions("runs/transitions.npz")
    >>> train, validation = split_transitions(data, validation_fraction=0.1)
"""

from __future__ import annotations

import json
import math
import os
import shutil
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from dlo_env.cord import MAX_PEGS, PEG_FAR, PEG_RADIUS, Cord, CordParams
from dlo_env.core.atomic import file_digest
from dlo_env.core.checks import fractions, positive, positive_ints
from dlo_env.dataset.chunks import (
    ChunkJob,
    Progress,
    check_out,
    chunk_path,
    chunk_plan,
    chunk_rng,
    run_chunks,
)
from dlo_env.dataset.npz_file import check_arrays, load_npz, save_npz
from dlo_env.errors import InputError
from dlo_env.randomize import TEST_CORDS, check_randomize, draw_params, test_cord
from dlo_env.shapes import TABLE_HALF, random_cord_shape, wavy_cord_shape, wide_cord_shape
from dlo_env.tasks import (
    DEFAULT_MAX_STEP,
    GRASP_ENDS,
    MAX_SETTLE_ACTIONS,
    apply_action,
    draw_pegs,
    random_start,
    split_move,
    wait_for_rest,
)

#: Name stored in every file's metadata.
FORMAT_NAME = "dlo-transitions"
#: Version of the file layout; bumped on any incompatible change. Version 2 added ``params``
#: (cords that differ), version 3 ``pegs`` and ``peg_count``; files of versions 1 and 2 still
#: load (their cord from their metadata; no pegs).
FORMAT_VERSION = 3
#: The versions ``load_transitions`` reads.
READABLE_VERSIONS = (1, 2, 3)
#: The cord parameters of every transition, the columns of ``params``.
PARAM_COLUMNS = ("length", "bending_stiffness", "friction", "mass")
#: Names of the grasp codes in ``grasp``.
GRASP_NAMES = ("head", "tail", "both")

_ARRAYS = {
    "start": (np.dtype(np.float32), ("T", "n", 2)),
    "next": (np.dtype(np.float32), ("T", "n", 2)),
    "grasp": (np.dtype(np.int8), ("T",)),
    "displacement": (np.dtype(np.float32), ("T", 2, 2)),
    "moved": (np.dtype(np.float32), ("T", 2, 2)),
    "episode": (np.dtype(np.int64), ("T",)),
    "step": (np.dtype(np.int64), ("T",)),
    "settle": (np.dtype(np.int8), ("T",)),
    "at_rest": (np.dtype(np.bool_), ("T",)),
    "params": (np.dtype(np.float32), ("T", 4)),
    "pegs": (np.dtype(np.float32), ("T", "p", 2)),
    "peg_count": (np.dtype(np.int8), ("T",)),
}
ARRAY_NAMES = tuple(_ARRAYS)
#: The arrays added after version 1, by the version that added them.
_SINCE = {"params": 2, "pegs": 3, "peg_count": 3}


def same_cord(a: CordParams, b: CordParams) -> bool:
    """Whether two cords have the same ``PARAM_COLUMNS`` (what a transition model is told)."""
    return all(math.isclose(getattr(a, k), getattr(b, k), rel_tol=1e-9) for k in PARAM_COLUMNS)


@dataclass(frozen=True)
class TransitionCollectConfig:
    """What to collect; the defaults produce the documented transition data.

    Attributes:
        seed: Root seed; chunk ``i`` uses the ``i``-th child of ``SeedSequence(seed)``.
        moves_per_episode: Moves applied to one cord after its random start.
        grasp_weights: Relative chances of an episode holding the head, the tail, or both
            ends (normalised to probabilities when drawn).
        min_move: Shortest move of an end, metres.
        max_move: Longest move of an end, metres.
        push_fraction: Share of moves aimed at the cord's middle (within +-60 degrees).
        rim_fraction: Share of moves aimed at the nearest table edge (within +-45 degrees).
        log_fraction: Share of move lengths drawn log-uniformly (the rest uniformly) from
            ``[min_move, max_move]``: planners end with short corrective moves, and a
            uniform draw alone gives few of them (4 % under 2.5 cm).
        wide_fraction: Share of episodes whose random start is drawn by
            :func:`dlo_env.shapes.wide_cord_shape` (hard bends, several bends, kinks) instead
            of :func:`dlo_env.shapes.random_cord_shape` (the environments' starts).
        wavy_fraction: Share of episodes whose random start is drawn by
            :func:`dlo_env.shapes.wavy_cord_shape` (smooth, bent both ways and several
            times as often as once); ``wide_fraction + wavy_fraction <= 1``.
        max_step: Gripper displacement of an action of 1.0 (the environments' ``max_step``).
        chunk_size: Transitions per chunk (the unit of parallel work, saving and resuming).
        cord: The cord simulated.
        randomize: Cord parameter -> ``[low, high]``: every episode's cord is ``cord`` with
            these drawn (``dlo_env.randomize``; empty: always ``cord``).
        test_cords: Every episode's cord is one of ``dlo_env.randomize.TEST_CORDS`` (drawn
            uniformly; with ``cord``'s other settings): data to test a model of several
            cords on cords it was not trained on. Not with ``randomize``.
        max_pegs: Every episode places 0 to ``max_pegs`` pegs (uniform count) near its start
            (0: an empty table, and no draws: earlier files reproduce).
        peg_radius: Radius of the pegs, metres.
    """

    seed: int = 0
    moves_per_episode: int = 5
    grasp_weights: tuple[float, float, float] = (0.3, 0.3, 0.4)
    min_move: float = 0.01
    max_move: float = 0.35
    push_fraction: float = 0.25
    rim_fraction: float = 0.1
    log_fraction: float = 0.5
    wide_fraction: float = 0.0
    wavy_fraction: float = 0.0
    max_step: float = DEFAULT_MAX_STEP
    chunk_size: int = 500
    cord: CordParams = field(default_factory=CordParams)
    randomize: dict[str, list[float]] = field(default_factory=dict)
    test_cords: bool = False
    max_pegs: int = 0
    peg_radius: float = PEG_RADIUS

    def __post_init__(self) -> None:
        if not (isinstance(self.max_pegs, (int, np.integer)) and not isinstance(self.max_pegs, bool)
                and 0 <= self.max_pegs <= MAX_PEGS):
            raise InputError(f"max_pegs must be an int from 0 to {MAX_PEGS}, got "
                             f"{self.max_pegs!r}", field="max_pegs")
        positive(self, "peg_radius")
        ranges = check_randomize(self.randomize)
        if self.test_cords and ranges:
            raise InputError("test_cords and randomize are two ways to choose the cords; give "
                             "one", field=("test_cords", "randomize"))
        object.__setattr__(self, "randomize", {k: list(v) for k, v in ranges.items()})
        if not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise InputError(f"seed must be an integer >= 0, got {self.seed!r}", field="seed")
        positive_ints(self, "moves_per_episode", "chunk_size")
        weights = np.asarray(self.grasp_weights, dtype=np.float64)
        if weights.shape != (3,) or not np.isfinite(weights).all() or (weights < 0).any() \
                or weights.sum() <= 0:
            raise InputError("grasp_weights must be 3 non-negative weights (head, tail, both) "
                             f"with a positive sum, got {self.grasp_weights!r}",
                             field="grasp_weights")
        if not 0.0 < self.min_move <= self.max_move:
            raise InputError("min_move and max_move must satisfy 0 < min_move <= max_move, "
                             f"got {self.min_move!r} and {self.max_move!r}",
                             field=("min_move", "max_move"))
        aims = (self.push_fraction, self.rim_fraction)
        if min(aims) < 0 or sum(aims) > 1:
            raise InputError("push_fraction and rim_fraction must be >= 0 with a sum <= 1, "
                             f"got {self.push_fraction!r} and {self.rim_fraction!r}",
                             field=("push_fraction", "rim_fraction"))
        fractions(self, "log_fraction", "wide_fraction", "wavy_fraction", closed_low=True)
        if self.wide_fraction + self.wavy_fraction > 1:
            raise InputError("wide_fraction and wavy_fraction must have a sum <= 1, got "
                             f"{self.wide_fraction!r} and {self.wavy_fraction!r}",
                             field=("wide_fraction", "wavy_fraction"))
        positive(self, "max_step")

    def to_json(self) -> dict[str, Any]:
        """The configuration as JSON-compatible values (tuples become lists)."""
        return json.loads(json.dumps(asdict(self)))


@dataclass(frozen=True, eq=False)
class TransitionDataset:
    """Transitions in memory; see the module docstring for every array."""

    start: np.ndarray
    next: np.ndarray
    grasp: np.ndarray
    displacement: np.ndarray
    moved: np.ndarray
    episode: np.ndarray
    step: np.ndarray
    settle: np.ndarray
    at_rest: np.ndarray
    params: np.ndarray | None = None
    pegs: np.ndarray | None = None
    peg_count: np.ndarray | None = None
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.pegs is None and self.peg_count is None:  # before version 3: no pegs
            object.__setattr__(self, "pegs", np.zeros((len(self.grasp), 0, 2), np.float32))
            object.__setattr__(self, "peg_count", np.zeros(len(self.grasp), np.int8))
        if self.params is None:  # a version-1 file, or arrays made without: the file's cord
            if not isinstance(self.metadata, dict):
                raise InputError(f"metadata must be a dict, got {type(self.metadata).__name__}")
            recorded = self.metadata.get("cord") or self.metadata.get("collect", {}).get("cord")
            cord = CordParams(**recorded) if recorded else CordParams()
            row = np.array([getattr(cord, k) for k in PARAM_COLUMNS], dtype=np.float32)
            object.__setattr__(self, "params", np.tile(row, (len(self.grasp), 1)))
        check_arrays(_ARRAYS, self.arrays())
        if len(self.grasp) and (self.grasp.min() < 0 or self.grasp.max() > 2):
            raise InputError("grasp must hold codes 0 (head), 1 (tail), 2 (both)")
        if len(self.grasp) and (self.peg_count.min() < 0
                                or self.peg_count.max() > self.pegs.shape[1]):
            raise InputError(f"peg_count must be in 0..{self.pegs.shape[1]} (the peg slots)")
        if not isinstance(self.metadata, dict):
            raise InputError(f"metadata must be a dict, got {type(self.metadata).__name__}")

    def __len__(self) -> int:
        return len(self.grasp)

    def one_cord(self, name: str = "data") -> CordParams:
        """The single cord of these transitions, or a one-line ``ValueError`` when they hold
        several (collected with ``randomize``) or differ from their metadata's cord."""
        if len(self) and (self.params != self.params[0]).any():
            raise InputError(f"{name} holds transitions of several cords (collected with "
                             "randomize), where one cord's are needed (a model that reads the "
                             "cord trains on several: --cord-inputs)")
        recorded = self.metadata.get("cord") or self.metadata.get("collect", {}).get("cord")
        cord = CordParams(**recorded) if recorded else CordParams()
        if len(self):
            row = np.array([getattr(cord, k) for k in PARAM_COLUMNS], dtype=np.float32)
            if (self.params[0] != row).any():
                raise InputError(f"{name} holds transitions of another cord than its metadata "
                                 f"says ({dict(zip(PARAM_COLUMNS, self.params[0].tolist()))}): "
                                 "a part of a randomised collection; use one cord's data")
        return cord

    def arrays(self) -> dict[str, np.ndarray]:
        """The arrays by file name (without ``metadata``)."""
        return {name: getattr(self, name) for name in ARRAY_NAMES}

    def subset(self, mask: np.ndarray) -> TransitionDataset:
        """The transitions where ``mask`` (bool or indices) selects."""
        return TransitionDataset(**{k: v[mask] for k, v in self.arrays().items()},
                                 metadata=dict(self.metadata))

    def end_displacement(self, index: np.ndarray | slice = slice(None)) -> np.ndarray:
        """Commanded displacement as the model takes it: ``(T, 2)`` for one end, head dx, dy
        then tail dx, dy ``(T, 4)`` for both; only valid for transitions of one grasp."""
        grasp = np.unique(self.grasp[index])
        if len(grasp) != 1:
            raise InputError("end_displacement needs transitions of a single grasp")
        d = self.displacement[index]
        return {0: d[:, 0], 1: d[:, 1], 2: d.reshape(-1, 4)}[int(grasp[0])]

    def env_steps(self, max_step: float | None = None) -> int:
        """Environment steps the transitions took to collect: each move's ``split_move``
        actions plus the zero actions of its settle (the sample cost of a model trained on
        them). ``max_step`` defaults to the collection's."""
        if max_step is None:
            max_step = float(self.metadata.get("collect", {}).get("max_step", DEFAULT_MAX_STEP))
        longest = np.linalg.norm(self.displacement.astype(np.float64), axis=-1).max(axis=-1)
        actions = np.maximum(1, np.ceil(longest / max_step - 1e-9))
        return int(actions.sum() + self.settle.astype(np.int64).sum())

    def peg_list(self, index: int) -> np.ndarray:
        """``(k, 2)`` centres of the pegs of transition ``index``."""
        return self.pegs[index, : int(self.peg_count[index])]

    def peg_rows(self, index: np.ndarray | slice = slice(None)) -> np.ndarray:
        """float32 ``(T, p, 2)`` pegs of the transitions ``index``, an empty slot at
        ``dlo_env.cord.PEG_FAR`` (where it touches nothing): what a model takes."""
        pegs = self.pegs[index].copy()
        empty = np.arange(pegs.shape[1])[None, :] >= self.peg_count[index][:, None]
        pegs[empty] = PEG_FAR
        return pegs

    @staticmethod
    def concatenate(parts: list[TransitionDataset]) -> TransitionDataset:
        """One dataset of ``parts`` in order; episodes are renumbered to stay distinct, and the
        peg slots padded to the most of any part."""
        arrays: dict[str, list[np.ndarray]] = {k: [] for k in ARRAY_NAMES}
        slots = max((part.pegs.shape[1] for part in parts), default=0)
        offset = 0
        for part in parts:
            for name, arr in part.arrays().items():
                if name == "pegs" and arr.shape[1] < slots:
                    arr = np.concatenate([arr, np.zeros((len(arr), slots - arr.shape[1], 2),
                                                        np.float32)], axis=1)
                arrays[name].append(arr + offset if name == "episode" else arr)
            offset += int(part.episode.max()) + 1 if len(part) else 0
        return TransitionDataset(**{k: np.concatenate(v) for k, v in arrays.items()})


# ---------------------------------------------------------------- one chunk
def _draw_move(rng: np.random.Generator, cord: Cord, config: TransitionCollectConfig) -> np.ndarray:
    """``(2 * ends,)`` commanded displacement of the held ends."""
    shape = cord.shape
    centre = shape.mean(axis=0)
    grippers = cord.gripper_positions()
    moves = []
    for end in GRASP_ENDS[cord.grasp]:
        pos = grippers[end]
        u = rng.uniform()
        if u < config.push_fraction:
            towards = centre - pos
            angle = math.atan2(towards[1], towards[0]) + rng.uniform(-1.0, 1.0) * np.pi / 3
        elif u < config.push_fraction + config.rim_fraction:
            axis = int(np.argmax(np.abs(pos)))
            edge = np.zeros(2)
            edge[axis] = 1.0 if pos[axis] >= 0 else -1.0
            angle = math.atan2(edge[1], edge[0]) + rng.uniform(-1.0, 1.0) * np.pi / 4
        else:
            angle = rng.uniform(-np.pi, np.pi)
        if rng.uniform() < config.log_fraction:  # short corrections as often as long moves
            length = math.exp(rng.uniform(math.log(config.min_move), math.log(config.max_move)))
        else:
            length = rng.uniform(config.min_move, config.max_move)
        moves.append(length * np.array([math.cos(angle), math.sin(angle)]))
    return np.concatenate(moves)


def _start_family(rng: np.random.Generator, config: TransitionCollectConfig
                  ) -> Callable[..., np.ndarray]:
    """The drawer of an episode's start: wide, wavy or the environments' random shapes."""
    # One draw, and none when both shares are 0: files collected before an option existed
    # (wavy_fraction 0; wide_fraction 0 too before that one) stay reproducible.
    if config.wide_fraction + config.wavy_fraction == 0:
        return random_cord_shape
    u = rng.uniform()
    if u < config.wide_fraction:
        return wide_cord_shape
    return wavy_cord_shape if u < config.wide_fraction + config.wavy_fraction else random_cord_shape


def carry_out(cord: Cord, move: np.ndarray, max_step: float
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """One transition on ``cord`` (at rest): the move as ``split_move`` actions through
    ``apply_action``, then zero actions until the cord is at rest.

    Args:
        cord: The cord, at rest; it is left at rest after the move.
        move: ``(2 * ends,)`` commanded displacement of the held ends (head first).
        max_step: Metres per unit action.

    Returns:
        The shape after, the commanded and the real displacement of [head, tail] ``(2, 2)``
        (zero for an end not held), and the zero actions the settle took.
    """
    before = cord.gripper_positions()
    for action in split_move(move, max_step):
        apply_action(cord, action, max_step)
    settle = wait_for_rest(cord, max_step)
    after = cord.gripper_positions()
    commanded = np.zeros((2, 2), dtype=np.float32)
    moved = np.zeros((2, 2), dtype=np.float32)
    for k, end in enumerate(GRASP_ENDS[cord.grasp]):
        row = 0 if end == "head" else 1
        commanded[row] = move[2 * k: 2 * k + 2]
        moved[row] = after[end] - before[end]
    return cord.shape, commanded, moved, settle


def collect_transition_chunk(config: TransitionCollectConfig, index: int, size: int,
                             progress: Progress | None = None) -> TransitionDataset:
    """Generate chunk ``index``: exactly ``size`` transitions (a prefix of a larger chunk)."""
    if size < 1:
        raise InputError(f"size must be >= 1, got {size!r}")
    rng = chunk_rng(config.seed, index)
    weights = np.asarray(config.grasp_weights, dtype=np.float64)
    weights = weights / weights.sum()
    rows: dict[str, list[Any]] = {k: [] for k in ARRAY_NAMES}
    started = time.perf_counter()
    episode = -1
    while len(rows["grasp"]) < size:
        episode += 1
        grasp = int(rng.choice(3, p=weights))
        # A draw only when randomising: files collected before stay reproducible.
        if config.test_cords:
            params = test_cord(int(rng.integers(len(TEST_CORDS))), config.cord)
        else:
            params = draw_params(config.cord, config.randomize, rng) if config.randomize \
                else config.cord
        cord = Cord(params, grasp=GRASP_NAMES[grasp], peg_radius=config.peg_radius)
        row = [getattr(params, k) for k in PARAM_COLUMNS]
        draw = _start_family(rng, config)
        cord.reset(random_start(rng, cord=cord, draw=draw))  # fresh, as an environment's reset
        start = cord.shape
        slots = np.zeros((config.max_pegs, 2), dtype=np.float32)
        if config.max_pegs:  # draws only with pegs: files collected before stay reproducible
            pegs = draw_pegs(rng, int(rng.integers(config.max_pegs + 1)), start,
                             config.peg_radius)
            cord.set_pegs(pegs)
            slots[: len(pegs)] = pegs
        for step in range(config.moves_per_episode):
            if len(rows["grasp"]) == size:
                break
            move = _draw_move(rng, cord, config)
            nxt, commanded, moved, settle = carry_out(cord, move, config.max_step)
            for name, value in (("start", start), ("next", nxt), ("grasp", grasp),
                                ("displacement", commanded), ("moved", moved),
                                ("episode", episode), ("step", step), ("settle", settle),
                                ("at_rest", settle < MAX_SETTLE_ACTIONS), ("params", row),
                                ("pegs", slots), ("peg_count", len(cord.pegs))):
                rows[name].append(value)
            start = nxt
            if progress is not None:
                progress(1, 0)
    meta = {"chunk": index, "episodes": episode + 1,
            "compute_time_s": time.perf_counter() - started, "collect": config.to_json()}
    return TransitionDataset(
        **{name: np.asarray(rows[name], dtype=dtype) for name, (dtype, _) in _ARRAYS.items()},
        metadata=meta)


# ---------------------------------------------------------------- files
def save_transitions(path: str | os.PathLike[str], data: TransitionDataset) -> Path:
    """Write ``data`` to ``path`` atomically (byte-identical for equal data)."""
    return save_npz(path, data.arrays(), data.metadata, FORMAT_NAME, FORMAT_VERSION)


def load_transitions(path: str | os.PathLike[str]) -> TransitionDataset:
    """Read and validate a transition dataset written by ``dlo collect transitions``.

    Raises:
        FileNotFoundError: No file at ``path``.
        ValueError: One line: not a transition dataset, another version, a bad array.
    """
    arrays, meta = load_npz(
        path, format_name=FORMAT_NAME, format_version=READABLE_VERSIONS,
        names=tuple(n for n in ARRAY_NAMES if n not in _SINCE), optional=tuple(_SINCE),
        what="transition dataset",
        missing_hint=("make one with `dlo collect transitions --num-transitions N "
                      f"--out {Path(path).name}`"))
    version = meta.get("format_version", FORMAT_VERSION)
    for name, since in _SINCE.items():
        if version >= since and name not in arrays:
            raise InputError(f"{str(path)!r} lacks the array {name} (format_version {version})")
    try:
        return TransitionDataset(**arrays, metadata=meta)
    except ValueError as exc:
        raise InputError(f"{str(path)!r}: {exc}") from exc


def load_transition_files(paths: str | os.PathLike[str] | list[str | os.PathLike[str]]
                          ) -> TransitionDataset:
    """The transitions of one or several files as one dataset, in order.

    Its metadata holds what the files share (the format, the cord, the collection settings
    they agree on, under ``collect``), ``files`` (the paths) and ``sources``: each file's path,
    count, SHA-256 digest and collection settings, so a model trained on them records exactly
    what it saw.

    Raises:
        FileNotFoundError: A path with no file.
        ValueError: One line: no paths, the same file twice, a file that ``load_transitions``
            refuses, or files collected with different cords or action sizes.
    """
    paths = [paths] if isinstance(paths, (str, os.PathLike)) else list(paths)
    if not paths:
        raise InputError("paths must name at least one transition file, got none")
    parts = [load_transitions(path) for path in paths]
    sources = [{"file": str(path), "transitions": len(part), "digest": file_digest(path),
                "collect": part.metadata.get("collect", {})} for path, part in zip(paths, parts)]
    first = parts[0].metadata
    for path, part, source in zip(paths[1:], parts[1:], sources[1:]):
        if part.metadata.get("cord") != first.get("cord"):
            raise InputError(f"{str(path)!r} was collected with another cord than "
                             f"{str(paths[0])!r}")
        if source["collect"].get("max_step") != sources[0]["collect"].get("max_step"):
            raise InputError(f"{str(path)!r} was collected with another max_step than "
                             f"{str(paths[0])!r}")
    digests = [source["digest"] for source in sources]
    for k, digest in enumerate(digests):
        if digest in digests[:k]:
            raise InputError(f"{str(paths[k])!r} holds the same transitions as "
                             f"{str(paths[digests.index(digest)])!r}; give each file once")
    shared = {k: v for k, v in sources[0]["collect"].items()
              if all(source["collect"].get(k) == v for source in sources)}
    keep = {k: first[k] for k in ("format", "format_version", "cord", "n_points", "grasp_names")
            if k in first}
    data = TransitionDataset.concatenate(parts)
    return TransitionDataset(**data.arrays(), metadata={
        **keep, "collect": shared, "files": [str(p) for p in paths], "sources": sources})


def split_transitions(data: TransitionDataset, validation_fraction: float = 0.1,
                      seed: int = 0) -> tuple[TransitionDataset, TransitionDataset]:
    """Split by whole episodes (moves of one cord stay on one side): ``(train, validation)``."""
    if not 0.0 < validation_fraction < 1.0:
        raise InputError(f"validation_fraction must be in (0, 1), got {validation_fraction!r}")
    episodes = np.unique(data.episode)
    if len(episodes) < 2:
        raise InputError(f"data must hold at least 2 episodes to split, got {len(episodes)}")
    order = np.random.default_rng(seed).permutation(episodes)
    take = min(max(1, round(validation_fraction * len(episodes))), len(episodes) - 1)
    validation = np.isin(data.episode, order[:take])
    return data.subset(~validation), data.subset(validation)


# ---------------------------------------------------------------- the collection job
def _write_chunk(config: TransitionCollectConfig, index: int, size: int, path: Path,
                 progress: Progress | None) -> None:
    save_transitions(path, collect_transition_chunk(config, index, size, progress))


def _chunk_size(path: Path) -> int:
    return len(load_transitions(path))


def transition_job(config: TransitionCollectConfig) -> ChunkJob:
    """The chunked job that collects transitions with ``config``."""
    return ChunkJob(kind="transitions", format_version=FORMAT_VERSION,
                    settings=config.to_json(), write=partial(_write_chunk, config),
                    size_of=_chunk_size, defaults=TransitionCollectConfig().to_json())


def collect_transitions(
    out: str | os.PathLike[str],
    num_transitions: int,
    config: TransitionCollectConfig | None = None,
    *,
    workers: int = 1,
    resume: bool = False,
    progress: Progress | None = None,
    backend: Any = None,
) -> TransitionDataset:
    """Collect ``num_transitions`` transitions into the ``.npz`` file ``out``.

    The arrays depend only on ``config`` and ``num_transitions`` (not on ``workers``); an
    interrupted run is continued with ``resume=True`` (nothing lost, nothing repeated).
    Workers are spawned, so a script calling this with ``workers > 1`` needs the
    ``if __name__ == "__main__":`` guard.
    ``backend`` (a :class:`dlo_env.core.ray_backend.RayBackend`) makes the chunks on Ray.

    Raises:
        ValueError: Bad arguments, an existing ``out``, or leftovers of another run.
        KeyboardInterrupt: Re-raised after the running chunks were saved.
    """
    config = config if config is not None else TransitionCollectConfig()
    if not isinstance(num_transitions, (int, np.integer)) or num_transitions < 1:
        raise InputError(f"num_transitions must be an integer >= 1, got {num_transitions!r}")
    out = check_out(out, resume=resume, workers=workers)
    started = time.perf_counter()
    plan = chunk_plan(int(num_transitions), config.chunk_size)
    parts, reused, reused_items = run_chunks(transition_job(config), out, plan,
                                             workers=int(workers), progress=progress,
                                             backend=backend)
    chunks = []
    compute = 0.0
    for index, size in plan:
        chunk = load_transitions(chunk_path(parts, index))
        compute += float(chunk.metadata.get("compute_time_s", 0.0))
        chunks.append(chunk.subset(np.arange(len(chunk)) < size))
    data = TransitionDataset.concatenate(chunks)
    metadata = {
        "num_transitions": len(data),
        "n_points": config.cord.n_points,
        "cord": asdict(config.cord),
        "collect": config.to_json(),
        "seed": config.seed,
        "workers": int(workers),
        "episodes": int(data.episode.max()) + 1,
        "grasp_names": list(GRASP_NAMES),
        "grasp_counts": np.bincount(data.grasp, minlength=3).tolist(),
        "near_rim": int((np.abs(data.next) > TABLE_HALF - 0.05).any(axis=(1, 2)).sum()),
        "chunks": len(plan),
        "chunks_resumed": reused,
        "transitions_resumed": reused_items,
        "compute_time_s": round(compute, 3),
        "wall_time_s": round(time.perf_counter() - started, 3),
    }
    data = TransitionDataset(**data.arrays(), metadata=metadata)
    save_transitions(out, data)
    shutil.rmtree(parts)
    return data
