"""Shape dataset collection: drive the cord with random straight moves and record shapes.

One *episode* starts from a random cord-like shape anywhere on the table
(:func:`dlo_env.shapes.random_cord_shape`) and applies ``moves_per_start`` straight moves to the
same cord, so no simulation is spent on settling or rebuilding. Each move picks which end(s)
to drive (head, tail or both; both only while the ends are closer than the span limit, since a
taut cord dragged sideways stretches), a random direction and length for each driven end, and
records the shape every ``record_every`` physics substeps *along* the move. A recorded shape is
kept when it passes the paper's cord-like filter (:func:`dlo_env.shapes.is_cord_like`) and no
segment is stretched more than ``max_stretch``. Every move is also stored as a transition
(shape before, ends, gripper displacement, shape after).

Work is cut into chunks of ``chunk_size`` shapes and run by :mod:`dlo_env.dataset.chunks`
(deterministic for a seed whatever the number of workers; resumable). The final file is
assembled in chunk order and the ``OUT.parts/`` folder is removed.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import time
from dataclasses import asdict, dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from dlo_env.cord import Cord, CordParams
from dlo_env.dataset.chunks import (
    ChunkJob,
    Progress,
    check_out,
    chunk_path,
    chunk_plan,
    chunk_rng,
    run_chunks,
)
from dlo_env.dataset.shape_file import (
    FORMAT_VERSION,
    GRASP_NAMES,
    ShapeDataset,
    load_shapes,
    save_shapes,
)
from dlo_env.errors import InputError
from dlo_env.shapes import (
    COSINE_THRESHOLD,
    TABLE_HALF,
    is_cord_like,
    random_cord_shape,
    segment_lengths,
)


@dataclass(frozen=True)
class CollectConfig:
    """What to collect; the defaults produce the documented datasets.

    Attributes:
        seed: Root seed; chunk ``i`` uses the ``i``-th child of ``SeedSequence(seed)``.
        cosine_threshold: The paper's cord-like filter threshold.
        record_every: Record a shape every this many physics substeps (10 substeps at the
            default 0.2 m/s is about 1 cm of gripper travel).
        max_stretch: Reject shapes with a segment longer or shorter than rest by more than this
            fraction.
        min_move: Shortest random displacement of a driven end, metres.
        max_move: Longest random displacement of a driven end, metres.
        moves_per_start: Moves applied to one cord before starting again from a new shape.
        grasp_weights: Probabilities of driving the head, the tail, or both ends.
        push_fraction: Chance that a driven end moves towards the cord's middle (within +-60
            degrees) rather than in a random direction; pushing both ends buckles the cord.
        both_span: Both ends are driven only while they are closer than
            ``both_span * max_span * length``.
        start_margin: Distance start shapes keep from the table edge, metres.
        chunk_size: Shapes per chunk (the unit of parallel work, saving and resuming).
        cord: The cord simulated.
    """

    seed: int = 0
    cosine_threshold: float = COSINE_THRESHOLD
    record_every: int = 10
    max_stretch: float = 0.02
    min_move: float = 0.05
    max_move: float = 0.4
    moves_per_start: int = 8
    grasp_weights: tuple[float, float, float] = (0.3, 0.3, 0.4)
    push_fraction: float = 0.3
    both_span: float = 0.95
    start_margin: float = 0.1
    chunk_size: int = 2000
    cord: CordParams = field(default_factory=CordParams)

    def __post_init__(self) -> None:
        if not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise InputError(f"seed must be an integer >= 0, got {self.seed!r}", field="seed")
        if not -1.0 <= self.cosine_threshold <= 1.0:
            raise InputError(f"cosine_threshold must be in [-1, 1], got {self.cosine_threshold!r}",
                             field="cosine_threshold")
        for name in ("record_every", "moves_per_start", "chunk_size"):
            value = getattr(self, name)
            if not isinstance(value, (int, np.integer)) or value < 1:
                raise InputError(f"{name} must be an integer >= 1, got {value!r}", field=name)
        if not 0.0 < self.max_stretch < 1.0:
            raise InputError(f"max_stretch must be in (0, 1), got {self.max_stretch!r}",
                             field="max_stretch")
        if not 0.0 < self.min_move <= self.max_move:
            raise InputError(
                f"min_move and max_move must satisfy 0 < min_move <= max_move, "
                f"got {self.min_move!r} and {self.max_move!r}",
                field=("min_move", "max_move"),
            )
        weights = np.asarray(self.grasp_weights, dtype=np.float64)
        if weights.shape != (3,) or (weights < 0).any() or weights[:2].sum() <= 0:
            raise InputError(
                "grasp_weights must be 3 non-negative weights (head, tail, both) with head or "
                f"tail > 0, got {self.grasp_weights!r}",
                field="grasp_weights",
            )
        if not 0.0 <= self.push_fraction <= 1.0:
            raise InputError(f"push_fraction must be in [0, 1], got {self.push_fraction!r}",
                             field="push_fraction")
        if not 0.0 < self.both_span <= 1.0:
            raise InputError(f"both_span must be in (0, 1], got {self.both_span!r}",
                             field="both_span")
        if not 0.0 <= self.start_margin < 0.5 * TABLE_HALF:
            raise InputError(f"start_margin must be in [0, {0.5 * TABLE_HALF}), "
                             f"got {self.start_margin!r}", field="start_margin")

    def to_json(self) -> dict[str, Any]:
        """The configuration as JSON-compatible values (tuples become lists)."""
        return json.loads(json.dumps(asdict(self)))


def _draw_displacements(
    rng: np.random.Generator, cord: Cord, config: CollectConfig
) -> dict[str, np.ndarray]:
    """Random displacement of every held end that is not mostly swallowed by the table rim."""
    p = cord.params
    lim = TABLE_HALF - p.rim_margin
    span = config.both_span * p.max_span * p.length
    grippers = cord.gripper_positions()
    shape = cord.shape
    centre = shape.mean(axis=0)
    moves: dict[str, np.ndarray] = {}
    for _ in range(50):
        moves = {}
        targets = {}
        reach = 0.0
        for end, pos in grippers.items():
            length = rng.uniform(config.min_move, config.max_move)
            if rng.uniform() < config.push_fraction:
                # Pushing an end towards the cord's middle buckles it: bends a pull never makes.
                towards = centre - pos
                angle = math.atan2(towards[1], towards[0]) + rng.uniform(-1.0, 1.0) * np.pi / 3
            else:
                angle = rng.uniform(-np.pi, np.pi)
            d = length * np.array([np.cos(angle), np.sin(angle)])
            moves[end] = d
            targets[end] = np.clip(pos + d, -lim, lim)
            reach = max(reach, float(np.linalg.norm(targets[end] - pos)))
        # A gripper at the rim pushing outwards barely moves and records near duplicates.
        if reach < 0.5 * config.min_move:
            continue
        # Both ends: end closer than the span limit; the gap along straight paths is convex
        # in time, so it never exceeds its value at the start or at the end.
        if len(targets) == 2 and np.linalg.norm(targets["tail"] - targets["head"]) > span:
            continue
        break
    return moves


def _acceptable(shapes: np.ndarray, config: CollectConfig) -> tuple[np.ndarray, np.ndarray]:
    """Masks ``(cord_like, not_stretched)`` of a batch ``(B, n, 2)``."""
    cord_like = np.asarray(is_cord_like(shapes, config.cosine_threshold), dtype=bool)
    rest = config.cord.segment
    stretch = np.abs(segment_lengths(shapes) / rest - 1.0).max(axis=-1, initial=0.0)
    return cord_like, stretch <= config.max_stretch


def collect_chunk(
    config: CollectConfig, index: int, num_shapes: int, progress: Progress | None = None
) -> ShapeDataset:
    """Generate chunk ``index``: exactly ``num_shapes`` accepted shapes and their moves.

    The chunk depends only on ``config`` and ``index``; a smaller ``num_shapes`` gives a prefix
    of a larger one.
    """
    if num_shapes < 1:
        raise InputError(f"num_shapes must be >= 1, got {num_shapes!r}")
    rng = chunk_rng(config.seed, index)
    p = config.cord
    weights = np.asarray(config.grasp_weights, dtype=np.float64)
    weights = weights / weights.sum()
    cord = Cord(p, grasp="head")
    shapes: list[np.ndarray] = []
    shape_transition: list[np.ndarray] = []
    before_list: list[np.ndarray] = []
    after_list: list[np.ndarray] = []
    grasps: list[int] = []
    displacements: list[np.ndarray] = []
    episodes: list[int] = []
    cord_like: list[bool] = []
    accepted = rejected_cosine = rejected_stretch = 0
    episode = -1
    moves_left = 0
    before = np.empty(0)
    before_ok = False
    started = time.perf_counter()
    while accepted < num_shapes:
        if moves_left == 0:
            start = random_cord_shape(rng, n_points=p.n_points, length=p.length,
                                      margin=config.start_margin,
                                      threshold=config.cosine_threshold)
            cord.reset(start)
            before = cord.shape
            before_ok = True
            episode += 1
            moves_left = config.moves_per_start
        grasp = int(rng.choice(3, p=weights))
        cord.set_grasp(GRASP_NAMES[grasp])
        moves = _draw_displacements(rng, cord, config)
        start_grip = cord.gripper_positions()
        recorded = cord.move(head=moves.get("head"), tail=moves.get("tail"),
                             record_every=config.record_every)
        end_grip = cord.gripper_positions()
        after = cord.shape
        disp = np.zeros((2, 2), dtype=np.float32)
        for row, end in enumerate(("head", "tail")):
            if end in start_grip:
                disp[row] = end_grip[end] - start_grip[end]
        ok_cos, ok_len = _acceptable(recorded, config)
        keep = ok_cos & ok_len
        n_rej_cos = int((~ok_cos).sum())
        n_rej_len = int((ok_cos & ~ok_len).sum())
        rejected_cosine += n_rej_cos
        rejected_stretch += n_rej_len
        kept = recorded[keep][: num_shapes - accepted]
        t = len(grasps)
        shapes.append(kept)
        shape_transition.append(np.full(len(kept), t, dtype=np.int64))
        after_cos, after_len = _acceptable(after[None], config)
        after_ok = bool(after_cos[0] and after_len[0])
        before_list.append(before)
        after_list.append(after)
        grasps.append(grasp)
        displacements.append(disp)
        episodes.append(episode)
        cord_like.append(before_ok and after_ok)
        accepted += len(kept)
        before, before_ok = after, after_ok
        moves_left -= 1
        if progress is not None:
            progress(len(kept), n_rej_cos + n_rej_len)
    n = p.n_points
    meta = {
        "chunk": index,
        "num_shapes": accepted,
        "rejected": {"cosine": rejected_cosine, "stretch": rejected_stretch},
        "moves": len(grasps),
        "episodes": episode + 1,
        "compute_time_s": time.perf_counter() - started,
        "collect": config.to_json(),
    }
    return ShapeDataset(
        shapes=np.concatenate(shapes).astype(np.float32).reshape(-1, n, 2),
        shape_transition=np.concatenate(shape_transition),
        transition_before=np.asarray(before_list, dtype=np.float32).reshape(-1, n, 2),
        transition_after=np.asarray(after_list, dtype=np.float32).reshape(-1, n, 2),
        transition_grasp=np.asarray(grasps, dtype=np.int8),
        transition_displacement=np.asarray(displacements, dtype=np.float32).reshape(-1, 2, 2),
        transition_episode=np.asarray(episodes, dtype=np.int64),
        transition_cord_like=np.asarray(cord_like, dtype=bool),
        metadata=meta,
    )


# ---------------------------------------------------------------- chunk files
def _write_chunk(config: CollectConfig, index: int, num_shapes: int, path: Path,
                 progress: Progress | None) -> None:
    save_shapes(path, collect_chunk(config, index, num_shapes, progress))


def _chunk_size(path: Path) -> int:
    return load_shapes(path).num_shapes


def shape_job(config: CollectConfig) -> ChunkJob:
    """The chunked job that collects shapes with ``config``."""
    return ChunkJob(kind="shapes", format_version=FORMAT_VERSION, settings=config.to_json(),
                    write=partial(_write_chunk, config), size_of=_chunk_size,
                    defaults=CollectConfig().to_json())


# ---------------------------------------------------------------- the collection job
def assemble(parts: Path, plan: list[tuple[int, int]]) -> tuple[ShapeDataset, dict[str, Any]]:
    """Concatenate the chunk files of ``plan`` in order into one dataset.

    Returns:
        The dataset (metadata empty) and the summed counts of the chunks.
    """
    pieces = []
    t_offset = e_offset = 0
    totals = {"rejected_cosine": 0, "rejected_stretch": 0, "compute_time_s": 0.0}
    for index, n in plan:
        chunk = load_shapes(chunk_path(parts, index))
        if chunk.num_shapes > n:  # made for a larger run; its prefix is this run's chunk
            last = int(chunk.shape_transition[n - 1])
            transitions = np.arange(chunk.num_transitions) <= last
            chunk = chunk.subset(np.arange(chunk.num_shapes) < n, transitions)
        m = chunk.metadata
        totals["rejected_cosine"] += int(m["rejected"]["cosine"])
        totals["rejected_stretch"] += int(m["rejected"]["stretch"])
        totals["compute_time_s"] += float(m["compute_time_s"])
        pieces.append((chunk, t_offset, e_offset))
        t_offset += chunk.num_transitions
        e_offset += int(chunk.transition_episode.max()) + 1
    arrays: dict[str, np.ndarray] = {}
    for name in ShapeDataset.__dataclass_fields__:
        if name == "metadata":
            continue
        parts_list = []
        for chunk, t_off, e_off in pieces:
            arr = getattr(chunk, name)
            if name == "shape_transition":
                arr = arr + t_off
            elif name == "transition_episode":
                arr = arr + e_off
            parts_list.append(arr)
        arrays[name] = np.concatenate(parts_list)
    return ShapeDataset(**arrays), totals


def collect(
    out: str | os.PathLike[str],
    num_shapes: int,
    config: CollectConfig | None = None,
    *,
    workers: int = 1,
    resume: bool = False,
    progress: Progress | None = None,
    backend: Any = None,
) -> ShapeDataset:
    """Collect ``num_shapes`` cord-like shapes into the ``.npz`` file ``out``.

    Args:
        out: The dataset file to write (``.npz``); its folder is created if needed.
        num_shapes: Shapes to collect.
        config: What to collect (defaults: the documented settings).
        workers: Worker processes (1 runs in this process). The arrays written do not depend
            on it; only the metadata records it. Workers are spawned, so a script calling
            this with ``workers > 1`` needs the ``if __name__ == "__main__":`` guard.
        resume: Continue an interrupted run from the chunks in ``OUT.parts/``.
        progress: Called as ``progress(accepted, rejected)`` with increments.
        backend: A :class:`dlo_env.core.ray_backend.RayBackend` to make the chunks on Ray
            instead of in ``workers`` local processes (same arrays).

    Returns:
        The dataset as written.

    Raises:
        ValueError: Bad arguments, an existing ``out``, or leftovers of another run (the
            message says what to do).
        KeyboardInterrupt: Re-raised after the running chunks were saved.
    """
    config = config if config is not None else CollectConfig()
    if not isinstance(num_shapes, (int, np.integer)) or num_shapes < 1:
        raise InputError(f"num_shapes must be an integer >= 1, got {num_shapes!r}")
    out = check_out(out, resume=resume, workers=workers)
    started = time.perf_counter()
    plan = chunk_plan(int(num_shapes), config.chunk_size)
    parts, reused, reused_shapes = run_chunks(shape_job(config), out, plan, workers=int(workers),
                                              progress=progress, backend=backend)
    dataset, totals = assemble(parts, plan)
    rejected = totals["rejected_cosine"] + totals["rejected_stretch"]
    metadata = {
        "num_shapes": dataset.num_shapes,
        "n_points": config.cord.n_points,
        "cord": asdict(config.cord),
        "collect": config.to_json(),
        "seed": config.seed,
        "workers": int(workers),
        "cosine_threshold": config.cosine_threshold,
        "record_every": config.record_every,
        "accepted": dataset.num_shapes,
        "rejected": {"cosine": totals["rejected_cosine"], "stretch": totals["rejected_stretch"],
                     "total": rejected},
        "moves": dataset.num_transitions,
        "episodes": int(dataset.transition_episode.max()) + 1,
        "chunks": len(plan),
        "chunks_resumed": reused,
        "shapes_resumed": reused_shapes,
        "grasp_names": list(GRASP_NAMES),
        "compute_time_s": round(totals["compute_time_s"], 3),
        "wall_time_s": round(time.perf_counter() - started, 3),
    }
    dataset = ShapeDataset(**dataset.arrays(), metadata=metadata)
    save_shapes(out, dataset)
    shutil.rmtree(parts)
    return dataset
