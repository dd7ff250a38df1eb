"""Reading shape datasets for training (``.npz`` files written by ``dlo collect``)."""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

import numpy as np

from dlo_env.dataset.npz_file import open_npz
from dlo_env.errors import InputError, MissingFileError


def load_shapes(path: str | os.PathLike, name: str = "path") -> np.ndarray:
    """The ``shapes`` array ``(N, n, 2)`` float32 of a dataset file.

    Files written by ``dlo collect`` (they carry ``metadata``) are read and validated by
    ``dlo_env.dataset.shape_file.load_shapes``; any other ``.npz`` with a ``shapes`` array is
    read with ``allow_pickle=False`` (e.g. a set of shapes to fine-tune on).

    Raises:
        FileNotFoundError: If the file does not exist.
        ValueError: Naming ``name`` if the file has no usable ``shapes`` array.
    """
    path = Path(path)
    if not path.is_file():
        raise MissingFileError(f"{name}: no dataset file at {str(path)!r}")
    archive = open_npz(path, f"{name}: {str(path)!r}")
    try:
        with archive as data:
            files = set(data.files)
            if "metadata" not in files:  # a plain shape array, e.g. shapes to fine-tune on
                if "shapes" not in files:
                    raise InputError(
                        f"{name}: {str(path)!r} has no 'shapes' array (found {sorted(files)})"
                    )
                shapes = data["shapes"]
    except (OSError, EOFError, zipfile.BadZipFile) as exc:
        raise InputError(f"{name}: {str(path)!r} is not a readable .npz file ({exc})") from exc
    if "metadata" in files:  # written by `dlo collect`: its loader checks the format
        from dlo_env.dataset.shape_file import load_shapes as collector_load

        try:
            shapes = collector_load(path).shapes
        except ValueError as exc:
            raise InputError(f"{name}: {exc}") from exc
    shapes = np.asarray(shapes, dtype=np.float32)
    if shapes.ndim != 3 or shapes.shape[-1] != 2 or len(shapes) == 0:
        raise InputError(
            f"{name}: 'shapes' must have shape (N, n, 2) with N > 0, got {shapes.shape}"
        )
    if not np.isfinite(shapes).all():
        raise InputError(f"{name}: 'shapes' holds NaN or infinite coordinates")
    return shapes


#: The groups of shapes the quality report is broken down by: shapes recorded while one end
#: was driven (what ``DLOEndpoint-v0`` does) and while both were (``DLODualEndpoint-v0``).
SHAPE_GROUPS = ("one end", "both ends")


def load_labelled_shapes(paths: str | os.PathLike | list, name: str = "path"
                         ) -> tuple[np.ndarray, np.ndarray | None]:
    """The shapes of one or several dataset files joined, and the group of each shape.

    Returns:
        ``(shapes (N, n, 2) float32, groups)``: ``groups`` is an ``(N,)`` array of indices into
        ``SHAPE_GROUPS`` (the ends driven during the move that recorded the shape), or None when
        a file is not a ``dlo collect`` file and so does not record its moves.

    Raises:
        ValueError: Naming ``name`` if a file is unusable or the files' point counts differ.
    """
    from dlo_env.dataset.shape_file import GRASP_NAMES

    paths = [paths] if isinstance(paths, (str, os.PathLike)) else list(paths)
    shapes, groups = [], []
    for path in paths:
        shapes.append(load_shapes(path, name=name))
        groups.append(None)
        with np.load(path, allow_pickle=False) as data:
            if {"metadata", "shape_transition", "transition_grasp"} <= set(data.files):
                grasp = data["transition_grasp"][data["shape_transition"]]
                groups[-1] = (grasp == GRASP_NAMES.index("both")).astype(np.int64)
    points = {s.shape[1] for s in shapes}
    if len(points) > 1:
        raise InputError(f"{name}: the files hold shapes of different point counts "
                         f"{sorted(points)}")
    joined = shapes[0] if len(shapes) == 1 else np.concatenate(shapes)
    labelled = None if any(g is None for g in groups) else np.concatenate(groups)
    return joined, labelled


def split_heldout(
    shapes: np.ndarray, fraction: float, seed: int
) -> tuple[np.ndarray, np.ndarray]:
    """Random (train, held-out) split of one dataset, for when no held-out file is given.

    Shapes recorded along the same move are near duplicates, so a held-out file collected with
    another seed is the honest measure; this split is a fallback.
    """
    if not 0.0 < fraction < 1.0:
        raise InputError(f"fraction must be in (0, 1), got {fraction!r}")
    order = np.random.default_rng(seed).permutation(len(shapes))
    cut = max(1, int(round(fraction * len(shapes))))
    return shapes[order[cut:]], shapes[order[:cut]]


def evaluation_subsets(
    shapes: np.ndarray, sizes: tuple[int, ...], seed: int = 0
) -> list[np.ndarray]:
    """Disjoint random subsets of a held-out set, one per size, the same for the same seed.

    Collected files are ordered by episode (hundreds of consecutive shapes come from one cord),
    so the first shapes of a file are a few near-duplicate clusters, not a sample of it. Every
    evaluation draws its reference and inversion sets with this function instead.
    """
    if any(not isinstance(k, (int, np.integer)) or k < 0 for k in sizes):
        raise InputError(f"sizes must be non-negative ints, got {sizes!r}")
    if sum(sizes) > len(shapes):
        raise InputError(f"the held-out set must hold at least {sum(sizes)} shapes "
                         f"(sizes {tuple(sizes)}), got {len(shapes)}")
    order = np.random.default_rng(seed).permutation(len(shapes))
    bounds = np.cumsum((0, *sizes))
    return [np.asarray(shapes)[np.sort(order[a:b])] for a, b in zip(bounds[:-1], bounds[1:])]
