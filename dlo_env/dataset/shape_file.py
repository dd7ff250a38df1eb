"""Shape datasets on disk: the ``.npz`` format written by ``dlo collect``, loading and splits.

A dataset file is a plain ``.npz`` (no pickles; read it with ``np.load(allow_pickle=False)``):

=========================== ============== =================================================
array                       dtype, shape   meaning
=========================== ============== =================================================
``shapes``                  f4 (N, n, 2)   cord-like shapes recorded along the moves, metres
``shape_transition``        i8 (N,)        the move (row of the ``transition_*`` arrays)
                                           during which each shape was recorded
``transition_before``       f4 (T, n, 2)   shape when the move starts
``transition_after``        f4 (T, n, 2)   shape when the move ends (not settled)
``transition_grasp``        i1 (T,)        ends moved: 0 head, 1 tail, 2 both
``transition_displacement`` f4 (T, 2, 2)   gripper displacement of [head, tail], metres;
                                           zero for an end that was not held
``transition_episode``      i8 (T,)        start shape the move belongs to (moves of one
                                           episode follow each other on the same cord)
``transition_cord_like``    ?  (T,)        whether ``before`` and ``after`` both pass the
                                           cord-like filter and the stretch limit
``metadata``                str ()         JSON: format version, cord parameters, collection
                                           settings, counts, wall time
=========================== ============== =================================================

Example:
    >>> data = load_shapes("train.npz")
    >>> data.shapes.shape          # (N, 20, 2) float32
    >>> train, validation = split(data, validation_fraction=0.1, seed=0)
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dlo_env.dataset.npz_file import check_arrays, load_npz, save_npz
from dlo_env.errors import InputError

#: Name stored in every file's metadata, so other ``.npz`` files are recognised as such.
FORMAT_NAME = "dlo-shapes"
#: Version of the file layout; bumped on any incompatible change.
FORMAT_VERSION = 1
#: Names of the grasp codes in ``transition_grasp``.
GRASP_NAMES = ("head", "tail", "both")

#: array name -> (dtype, shape with "N", "T", "n" symbols)
_ARRAYS: dict[str, tuple[np.dtype, tuple[object, ...]]] = {
    "shapes": (np.dtype(np.float32), ("N", "n", 2)),
    "shape_transition": (np.dtype(np.int64), ("N",)),
    "transition_before": (np.dtype(np.float32), ("T", "n", 2)),
    "transition_after": (np.dtype(np.float32), ("T", "n", 2)),
    "transition_grasp": (np.dtype(np.int8), ("T",)),
    "transition_displacement": (np.dtype(np.float32), ("T", 2, 2)),
    "transition_episode": (np.dtype(np.int64), ("T",)),
    "transition_cord_like": (np.dtype(np.bool_), ("T",)),
}
ARRAY_NAMES = tuple(_ARRAYS)


@dataclass(frozen=True, eq=False)
class ShapeDataset:
    """A shape dataset in memory; see the module docstring for every array.

    Attributes:
        shapes: ``(N, n, 2)`` float32 cord-like shapes, metres (what a shape model trains on).
        shape_transition: ``(N,)`` int64 move during which each shape was recorded.
        transition_before: ``(T, n, 2)`` float32 shape at the start of each move.
        transition_after: ``(T, n, 2)`` float32 shape at the end of each move.
        transition_grasp: ``(T,)`` int8 ends moved (index into ``GRASP_NAMES``).
        transition_displacement: ``(T, 2, 2)`` float32 displacement of the [head, tail] gripper.
        transition_episode: ``(T,)`` int64 episode (start shape) of each move.
        transition_cord_like: ``(T,)`` bool, both ends of the transition pass the filter.
        metadata: Format version, cord parameters, collection settings and counts.
    """

    shapes: np.ndarray
    shape_transition: np.ndarray
    transition_before: np.ndarray
    transition_after: np.ndarray
    transition_grasp: np.ndarray
    transition_displacement: np.ndarray
    transition_episode: np.ndarray
    transition_cord_like: np.ndarray
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        check_arrays(_ARRAYS, self.arrays())
        t = len(self.transition_grasp)
        if len(self.shape_transition) and (
            self.shape_transition.min() < 0 or self.shape_transition.max() >= t
        ):
            raise InputError(f"shape_transition must index the {t} transitions, got values "
                             f"from {self.shape_transition.min()} to {self.shape_transition.max()}")
        if t and (self.transition_grasp.min() < 0 or self.transition_grasp.max() > 2):
            raise InputError("transition_grasp must hold codes 0 (head), 1 (tail), 2 (both)")
        if not isinstance(self.metadata, dict):
            raise InputError(f"metadata must be a dict, got {type(self.metadata).__name__}")

    @property
    def num_shapes(self) -> int:
        """Number of shapes ``N``."""
        return len(self.shapes)

    @property
    def num_transitions(self) -> int:
        """Number of moves ``T``."""
        return len(self.transition_grasp)

    def arrays(self) -> dict[str, np.ndarray]:
        """The arrays by file name (without ``metadata``)."""
        return {name: getattr(self, name) for name in ARRAY_NAMES}

    def subset(self, shape_mask: np.ndarray, transition_mask: np.ndarray) -> ShapeDataset:
        """The dataset restricted to some shapes and moves.

        Every kept shape must come from a kept move, so ``shape_transition`` can be renumbered.
        """
        shape_mask = np.asarray(shape_mask, dtype=bool)
        transition_mask = np.asarray(transition_mask, dtype=bool)
        if not transition_mask[self.shape_transition[shape_mask]].all():
            raise InputError("shape_mask keeps shapes whose transitions transition_mask drops")
        renumber = np.cumsum(transition_mask) - 1
        arrays = {name: arr[transition_mask] for name, arr in self.arrays().items()
                  if name.startswith("transition_")}
        return ShapeDataset(
            shapes=self.shapes[shape_mask],
            shape_transition=renumber[self.shape_transition[shape_mask]].astype(np.int64),
            metadata=dict(self.metadata),
            **arrays,
        )


def save_shapes(path: str | os.PathLike[str], dataset: ShapeDataset) -> Path:
    """Write ``dataset`` to ``path`` atomically, as a ``.npz`` with a JSON metadata string.

    The zip entries carry a fixed timestamp, so equal datasets give byte-identical files.

    Returns:
        The path written.
    """
    return save_npz(path, dataset.arrays(), dataset.metadata, FORMAT_NAME, FORMAT_VERSION)


def load_shapes(path: str | os.PathLike[str]) -> ShapeDataset:
    """Read and validate a shape dataset written by ``dlo collect``.

    Args:
        path: The ``.npz`` file.

    Returns:
        The dataset; ``shapes`` is float32 ``(N, n, 2)``.

    Raises:
        FileNotFoundError: There is no file at ``path``.
        ValueError: The file is not a shape dataset, has another format version, or an array
            is missing or of the wrong dtype or shape (the message names it).
    """
    arrays, meta = load_npz(
        path, format_name=FORMAT_NAME, format_version=FORMAT_VERSION, names=ARRAY_NAMES,
        what="shape dataset",
        missing_hint=f"make one with `dlo collect shapes --num-shapes N --out {Path(path).name}`")
    try:
        return ShapeDataset(**arrays, metadata=meta)
    except ValueError as exc:
        raise InputError(f"{str(path)!r}: {exc}") from exc


def split(
    dataset: ShapeDataset, validation_fraction: float = 0.1, seed: int = 0
) -> tuple[ShapeDataset, ShapeDataset]:
    """Split into training and validation sets by whole episodes.

    Shapes recorded on the same cord a centimetre apart are near duplicates, so episodes
    (a start shape and its moves) go entirely to one side; a seeded permutation of the
    episodes fills the validation set until it holds ``validation_fraction`` of the shapes.

    Args:
        dataset: The dataset to split.
        validation_fraction: Share of the shapes for validation, in ``(0, 1)``.
        seed: Seed of the permutation of episodes.

    Returns:
        ``(train, validation)``.
    """
    if not 0.0 < validation_fraction < 1.0:
        raise InputError(f"validation_fraction must be in (0, 1), got {validation_fraction!r}")
    episodes, per_move = np.unique(dataset.transition_episode, return_inverse=True)
    if len(episodes) < 2:
        raise InputError(f"dataset must hold at least 2 episodes to split, got {len(episodes)}")
    shape_episode = per_move[dataset.shape_transition]
    counts = np.bincount(shape_episode, minlength=len(episodes))
    order = np.random.default_rng(seed).permutation(len(episodes))
    need = validation_fraction * dataset.num_shapes
    take = int(np.searchsorted(np.cumsum(counts[order]), need)) + 1
    take = min(max(take, 1), len(episodes) - 1)
    is_validation = np.zeros(len(episodes), dtype=bool)
    is_validation[order[:take]] = True
    move_validation = is_validation[per_move]
    shape_validation = is_validation[shape_episode]
    parts = []
    for side in (False, True):
        part = dataset.subset(shape_validation == side, move_validation == side)
        part.metadata["split"] = {
            "part": "validation" if side else "train",
            "validation_fraction": validation_fraction,
            "seed": seed,
        }
        parts.append(part)
    return parts[0], parts[1]
