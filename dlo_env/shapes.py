"""Cord shapes: distances, the cord-like filter, validation and random drawing.

A shape is a float32 array ``(n, 2)`` of point positions in world metres; a batch is
``(B, n, 2)``. Point 0 is the head, point n-1 the tail. This module is the one place
where shape distance, the paper's cosine filter and segment spacing are implemented;
everything else in the project imports them from here.
"""

from __future__ import annotations

import numbers
from collections.abc import Callable

import numpy as np

from dlo_env.errors import InputError

#: Half the side of the square table, metres: the table is ``[-TABLE_HALF, TABLE_HALF]^2``.
TABLE_HALF = 1.0
#: The paper's cord-like threshold on the cosine of consecutive segment directions.
COSINE_THRESHOLD = 0.25
#: Relative tolerance on every segment length when a shape is validated as a cord.
SEGMENT_TOLERANCE = 0.05


def unflatten(shapes: object, n_points: int | None = None, dtype: type = np.float64
              ) -> np.ndarray:
    """``shapes`` as points ``(..., n, 2)``: flat shapes ``(2n,)`` or ``(B, 2n)``, as
    observations hold them, are reshaped; ``(..., n, 2)`` arrays are returned as they are.

    Args:
        shapes: One shape or a batch, flat or as points.
        n_points: The cord's points, if known: a flat shape must then have ``2 * n_points``
            numbers. Without it, any last axis other than 2 of even length is a flat shape.
        dtype: The array's dtype.
    """
    arr = np.asarray(shapes, dtype=dtype)
    if arr.ndim in (1, 2) and arr.shape[-1] != 2 and arr.shape[-1] % 2 == 0 and (
            n_points is None or arr.shape[-1] == 2 * n_points):
        arr = arr.reshape(arr.shape[:-1] + (arr.shape[-1] // 2, 2))
    return arr


def _points(shapes: object) -> np.ndarray:
    arr = unflatten(shapes)
    if arr.ndim < 2 or arr.shape[-1] != 2:
        raise InputError(f"shapes must be (..., n, 2) points or flat (2n,) / (B, 2n), got shape "
                         f"{arr.shape}")
    return arr


def _point_distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    # (..., n) distances between corresponding points: the arithmetic of
    # ``np.linalg.norm(diff, axis=-1)`` (the root of the summed squares; a sum of two is one
    # addition), without its checks, which cost more than the arithmetic on one shape (the
    # environments compute it every step).
    d = _points(a) - _points(b)
    d *= d
    return np.sqrt(d[..., 0] + d[..., 1])


def error(a: np.ndarray, b: np.ndarray) -> np.ndarray | float:
    """Mean over points of the Euclidean distance between corresponding points.

    Args:
        a: Shape ``(..., n, 2)``, or flat ``(2n,)`` / ``(B, 2n)``.
        b: Shape ``(..., n, 2)`` (or flat), broadcastable against ``a``.

    Returns:
        The distance in metres, of shape ``a.shape[:-2]`` (a float for single shapes).
    """
    d = _point_distances(a, b)
    out = np.add.reduce(d, axis=-1) / d.shape[-1]  # d.mean(axis=-1), bit for bit
    return float(out) if out.ndim == 0 else out


def max_error(a: np.ndarray, b: np.ndarray) -> np.ndarray | float:
    """Largest per-point Euclidean distance between two shapes (or batches, flat or as
    points), metres."""
    d = _point_distances(a, b)
    out = d.max(axis=-1)
    return float(out) if out.ndim == 0 else out


def direction_free_error(a: np.ndarray, b: np.ndarray) -> np.ndarray | float:
    """``error`` ignoring which end is which: the smaller of the errors against ``b`` and
    against ``b`` reversed (point n-1 first), metres. For designed goals, where the user does
    not care where each end lies.

    Args:
        a: Shape ``(..., n, 2)`` (or flat).
        b: Shape ``(..., n, 2)`` (or flat), broadcastable against ``a``.
    """
    b = _points(b)
    out = np.minimum(error(a, b), error(a, b[..., ::-1, :]))
    return float(out) if np.ndim(out) == 0 else out


#: The distances an environment can judge success by (``success_metric``): the ordered error,
#: or the error ignoring which end is which (designed goals).
SUCCESS_METRICS = {"error": error, "direction_free_error": direction_free_error}

#: Distance from the goal curve within which a point counts as on it, metres: the bead
#: threshold of DeformableRavens' cable-shape tasks.
BEAD_TOLERANCE = 0.0175


def bead_share(a: np.ndarray, goal: np.ndarray,
               tolerance: float = BEAD_TOLERANCE) -> np.ndarray | float:
    """Share of the points of ``a`` within ``tolerance`` of the goal's polyline (the segments
    between its consecutive points), in ``[0, 1]``: DeformableRavens' bead metric. It ignores
    the order of the points and which end is which.

    Args:
        a: Shape ``(..., n, 2)`` (or flat).
        goal: Shape ``(..., m, 2)`` (or flat), broadcastable against ``a`` but for the points.
        tolerance: Metres.
    """
    if isinstance(tolerance, bool) or not (isinstance(tolerance, numbers.Real) and tolerance >= 0):
        raise InputError(f"tolerance must be a number >= 0 (metres), got {tolerance!r}")
    pts = _points(a)[..., :, None, :]  # (..., n, 1, 2)
    g = _points(goal)
    if g.shape[-2] < 2:
        raise InputError(f"goal must have at least 2 points (a polyline), got {g.shape[-2]}")
    g = g[..., None, :, :]  # (..., 1, m, 2)
    start, seg = g[..., :-1, :], np.diff(g, axis=-2)  # (..., 1, m-1, 2)
    length2 = np.maximum((seg * seg).sum(axis=-1), 1e-18)
    rel = pts - start
    t = np.clip((rel * seg).sum(axis=-1) / length2, 0.0, 1.0)
    off = rel - t[..., None] * seg
    distance2 = (off * off).sum(axis=-1).min(axis=-1)  # (..., n) squared
    out = (distance2 <= tolerance * tolerance).mean(axis=-1)
    return float(out) if np.ndim(out) == 0 else out


def segment_vectors(shapes: np.ndarray) -> np.ndarray:
    """Difference vectors between consecutive points, ``(..., n-1, 2)``."""
    shapes = np.asarray(shapes)
    return shapes[..., 1:, :] - shapes[..., :-1, :]


def segment_lengths(shapes: np.ndarray) -> np.ndarray:
    """Distances between consecutive points, ``(..., n-1)``."""
    return np.linalg.norm(segment_vectors(shapes), axis=-1)


def turning_cosines(shapes: np.ndarray) -> np.ndarray:
    """Cosine similarity of consecutive segment vectors, ``(..., n-2)``.

    A zero-length segment gives cosine 0 (it has no direction).
    """
    v = segment_vectors(np.asarray(shapes, dtype=np.float64))
    norm = np.linalg.norm(v, axis=-1)
    dot = (v[..., 1:, :] * v[..., :-1, :]).sum(axis=-1)
    denom = norm[..., 1:] * norm[..., :-1]
    return np.divide(dot, denom, out=np.zeros_like(dot), where=denom > 0)


def is_cord_like(shapes: np.ndarray, threshold: float = COSINE_THRESHOLD) -> np.ndarray | bool:
    """The paper's filter: every pair of consecutive segments has cosine >= ``threshold``.

    Args:
        shapes: ``(n, 2)`` or ``(B, n, 2)``.
        threshold: Minimum cosine similarity, in ``[-1, 1]``.

    Returns:
        A bool for one shape, a bool array ``(B,)`` for a batch.
    """
    if not -1.0 <= threshold <= 1.0:
        raise InputError(f"threshold must be in [-1, 1], got {threshold!r}")
    ok = (turning_cosines(shapes) >= threshold).all(axis=-1)
    return bool(ok) if np.ndim(ok) == 0 else ok


def spacing_cv(shapes: np.ndarray) -> np.ndarray | float:
    """Coefficient of variation of the segment lengths of each shape (0 for even spacing)."""
    lengths = segment_lengths(np.asarray(shapes, dtype=np.float64))
    cv = lengths.std(axis=-1) / np.maximum(lengths.mean(axis=-1), 1e-12)
    return float(cv) if np.ndim(cv) == 0 else cv


def cord_length(shapes: np.ndarray) -> np.ndarray | float:
    """Polyline length of each shape, metres."""
    out = segment_lengths(np.asarray(shapes, dtype=np.float64)).sum(axis=-1)
    return float(out) if np.ndim(out) == 0 else out


def on_table(shapes: np.ndarray, half: float = TABLE_HALF) -> np.ndarray | bool:
    """Whether every point of each shape lies on the table square ``[-half, half]^2``."""
    ok = (np.abs(np.asarray(shapes)) <= half).all(axis=(-1, -2))
    return bool(ok) if np.ndim(ok) == 0 else ok


def as_points(
    value: object, n_points: int, name: str = "shape", dtype: type = np.float32,
    context: str = "",
) -> np.ndarray:
    """``value`` as finite ``(n_points, 2)`` points; accepts ``(n, 2)`` or flat ``(2n,)``.

    Only size and finiteness are checked (``validate_shape`` checks a whole cord).

    Raises:
        ValueError: Naming ``name`` (followed by ``context``) when the size is wrong or a
            coordinate is not finite.
    """
    arr = np.asarray(value, dtype=dtype)
    if arr.shape == (2 * n_points,):
        arr = arr.reshape(n_points, 2)
    if arr.shape != (n_points, 2):
        raise InputError(
            f"{name} must have shape ({n_points}, 2) or ({2 * n_points},){context}, "
            f"got {arr.shape}"
        )
    if not np.isfinite(arr).all():
        raise InputError(f"{name} must be finite, got NaN or infinite coordinates")
    return arr


def validate_shape(
    shape: object,
    *,
    n_points: int,
    length: float,
    name: str = "shape",
    tolerance: float = SEGMENT_TOLERANCE,
) -> np.ndarray:
    """Check that ``shape`` is one cord configuration and return it as float32 ``(n, 2)``.

    Args:
        shape: Array-like, ``(n_points, 2)`` or flat ``(2 * n_points,)``.
        n_points: Number of points of the cord.
        length: Length of the cord, metres.
        name: The argument's name, used in error messages.
        tolerance: Allowed relative deviation of every segment from ``length / (n_points - 1)``.

    Raises:
        ValueError: Naming ``name`` when the shape is of the wrong size, not finite, off the
            table, or its segments are not of the cord's rest length.
    """
    arr = as_points(shape, n_points, name, dtype=np.float64)
    if not on_table(arr):
        raise InputError(
            f"{name} must lie on the table [-{TABLE_HALF}, {TABLE_HALF}]^2 m, "
            f"got coordinates up to {np.abs(arr).max():.3f} m"
        )
    rest = length / (n_points - 1)
    seg = segment_lengths(arr)
    worst = float(np.abs(seg / rest - 1.0).max())
    if worst > tolerance:
        raise InputError(
            f"{name} must be a cord of length {length} m: every segment within "
            f"{tolerance:.0%} of {rest:.4f} m, got segments from {seg.min():.4f} to "
            f"{seg.max():.4f} m"
        )
    return arr.astype(np.float32)


def shape_from_headings(headings: np.ndarray, segment: float, origin: np.ndarray) -> np.ndarray:
    """Points of a chain with given segment headings (radians), ``(..., n-1) -> (..., n, 2)``."""
    steps = segment * np.stack([np.cos(headings), np.sin(headings)], axis=-1)
    zeros = np.zeros(steps.shape[:-2] + (1, 2))
    return np.asarray(origin)[..., None, :] + np.concatenate(
        [zeros, np.cumsum(steps, axis=-2)], axis=-2
    )


def onto_table(shape: np.ndarray, half: float = TABLE_HALF) -> np.ndarray:
    """``shape`` ``(n, 2)`` shifted by the least amount that puts every point on the table
    ``[-half, half]^2`` (unchanged, bit for bit, when it lies there; a shape wider than the
    table stays over its far edge)."""
    shape = np.asarray(shape, dtype=np.float64)
    shape = shape - np.clip(shape.max(axis=0) - half, 0.0, None)
    return shape + np.clip(-half - shape.min(axis=0), 0.0, None)


def at_segment_length(shape: np.ndarray, segment: float) -> np.ndarray:
    """``shape`` ``(n, 2)`` as a cord whose every segment is ``segment`` long: its segment
    directions laid out from its head, shifted back onto the table where the result would
    poke over the rim (float64). What ``Cord.reset`` starts from: a shape whose segments are
    already ``segment`` long, laid out within the table, keeps its head bit for bit."""
    shape = np.asarray(shape, dtype=np.float64)
    steps = np.diff(shape, axis=0)
    return onto_table(shape_from_headings(np.arctan2(steps[:, 1], steps[:, 0]), segment,
                                          shape[0]))


def random_cord_shape(
    rng: np.random.Generator,
    *,
    n_points: int = 20,
    length: float = 1.0,
    margin: float = 0.1,
    max_curvature: float = 9.0,
    threshold: float = COSINE_THRESHOLD,
) -> np.ndarray:
    """Draw a smooth, cord-like shape of exact segment length, anywhere on the table.

    The curvature along the cord is a random low-frequency Fourier series (straight lines,
    arcs, S-curves and hooks all occur), clipped to ``max_curvature`` (1/m); the shape is
    then rotated uniformly and placed uniformly where it fits inside the table with
    ``margin``.

    Args:
        rng: Source of randomness.
        n_points: Number of points.
        length: Cord length, metres.
        margin: Distance every point keeps from the table edge, metres.
        max_curvature: Largest curvature, 1/m.
        threshold: The cord-like filter the shape must pass.

    Returns:
        float32 ``(n_points, 2)``.
    """
    segment = length / (n_points - 1)
    s = (np.arange(n_points - 2) + 0.5) / (n_points - 2)

    def turns() -> np.ndarray:
        scale = rng.choice([0.5, 2.0, 5.0])
        modes = np.arange(4)
        coef = rng.normal(0.0, scale / (1.0 + modes), size=4)
        phase = rng.uniform(0.0, 2.0 * np.pi, size=4)
        kappa = (coef * np.cos(np.pi * modes * s[:, None] + phase)).sum(axis=1)
        return np.clip(kappa, -max_curvature, max_curvature) * segment

    return _first_placed(rng, turns, segment, margin, threshold, "a cord shape")


def random_cord_shapes(
    rng: np.random.Generator,
    count: int,
    *,
    n_points: int = 20,
    length: float = 1.0,
    margin: float = 0.1,
    max_curvature: float = 9.0,
) -> np.ndarray:
    """``count`` shapes from :func:`random_cord_shape`'s distribution, drawn as one batch.

    The same curvature series, rotation and placement, from whole-batch draws (so not the
    same shapes as ``count`` calls of ``random_cord_shape`` with that generator). With the
    default curvature bound every joint turns less than the cord-like filter allows, so no
    shape is redrawn for it; a shape that does not fit on the table with ``margin`` is.

    Returns:
        float32 ``(count, n_points, 2)``.
    """
    segment = length / (n_points - 1)
    s = (np.arange(n_points - 2) + 0.5) / (n_points - 2)
    modes = np.arange(4)
    half = TABLE_HALF - margin
    out = np.empty((count, n_points, 2), dtype=np.float32)
    todo = np.arange(count)
    for _ in range(1000):
        if not len(todo):
            return out
        k = len(todo)
        scale = rng.choice([0.5, 2.0, 5.0], size=(k, 1))
        coef = rng.normal(0.0, 1.0, size=(k, 4)) * scale / (1.0 + modes)
        phase = rng.uniform(0.0, 2.0 * np.pi, size=(k, 4))
        kappa = (coef[:, None] * np.cos(np.pi * modes * s[:, None] + phase[:, None])).sum(-1)
        turns = np.clip(kappa, -max_curvature, max_curvature) * segment
        headings = rng.uniform(-np.pi, np.pi, size=(k, 1)) + np.concatenate(
            [np.zeros((k, 1)), np.cumsum(turns, axis=1)], axis=1)
        shape = shape_from_headings(headings, segment, np.zeros((k, 2)))
        shape -= shape.mean(axis=1, keepdims=True)
        room_lo, room_hi = -half - shape.min(axis=1), half - shape.max(axis=1)
        ok = (room_lo <= room_hi).all(axis=1) & is_cord_like(shape)
        place = rng.uniform(size=(k, 2))
        shape += (room_lo + place * (room_hi - room_lo))[:, None]
        out[todo[ok]] = shape[ok]
        todo = todo[~ok]
    raise RuntimeError(f"could not draw cord shapes that fit on the table with margin {margin}")


def _check_threshold(threshold: float) -> None:
    """The cord-like filter's least cosine must be in ``[-1, 1)``."""
    if not -1.0 <= threshold < 1.0:
        raise InputError(f"threshold must be in [-1, 1), got {threshold!r}")


def _first_placed(rng: np.random.Generator, turns: Callable[[], np.ndarray], segment: float,
                  margin: float, threshold: float | None, what: str) -> np.ndarray:
    # Up to 1000 tries: joint turns from ``turns()``, then the chain at a uniform heading and a
    # uniform place where it fits on the table with ``margin`` and passes the cord-like filter
    # (``threshold``; None: no filter).
    half = TABLE_HALF - margin
    for _ in range(1000):
        chain = turns()
        headings = rng.uniform(-np.pi, np.pi) + np.concatenate([[0.0], np.cumsum(chain)])
        shape = shape_from_headings(headings, segment, np.zeros(2))
        shape -= shape.mean(axis=0)
        room_lo, room_hi = -half - shape.min(axis=0), half - shape.max(axis=0)
        if (room_lo > room_hi).any() or (threshold is not None
                                         and not is_cord_like(shape, threshold)):
            continue
        return (shape + rng.uniform(room_lo, room_hi)).astype(np.float32)
    raise RuntimeError(f"could not draw {what} that fits on the table with margin {margin}")


def wide_cord_shape(
    rng: np.random.Generator,
    *,
    n_points: int = 20,
    length: float = 1.0,
    margin: float = 0.1,
    max_curvature: float = 9.0,
    threshold: float = COSINE_THRESHOLD,
    kinks: float = 1.0,
) -> np.ndarray:
    """Draw a cord-like shape from a wider family than :func:`random_cord_shape`.

    ``random_cord_shape`` rarely bends the cord hard more than once (its higher Fourier modes
    are weak), so tight S-shapes, waves and kinked cords are scarce in what it draws. Here the
    curvature runs linearly between 2 to 6 evenly spaced knots along the cord, each uniform in
    ``(-peak, peak)`` with ``peak = max_curvature * sqrt(u)``, ``u`` uniform in ``(0, 1)``;
    then a Poisson(``kinks``) number of joints get a turn of 0.3 rad up to 95 % of the
    cord-like filter's limit ``arccos(threshold)``, either way, in place of the smooth one
    (the smooth part turns a joint by at most ``max_curvature`` times a segment, 0.47 rad for
    the default cord). Placed as ``random_cord_shape`` places.

    Args:
        rng: Source of randomness.
        n_points: Number of points.
        length: Cord length, metres.
        margin: Distance every point keeps from the table edge, metres.
        max_curvature: Largest curvature of the smooth part, 1/m.
        threshold: The cord-like filter the shape must pass, in ``[-1, 1)``.
        kinks: Mean number of kinked joints, ``>= 0``.

    Returns:
        float32 ``(n_points, 2)``.
    """
    _check_threshold(threshold)
    if not kinks >= 0:
        raise InputError(f"kinks must be a number >= 0, got {kinks!r}")
    segment = length / (n_points - 1)
    joints = n_points - 2
    s = (np.arange(joints) + 0.5) / joints
    sharpest = 0.95 * float(np.arccos(threshold))

    def turns() -> np.ndarray:
        knots = int(rng.integers(2, 7))
        values = rng.uniform(-1.0, 1.0, size=knots) * max_curvature * np.sqrt(rng.uniform())
        smooth = np.interp(s, np.linspace(0.0, 1.0, knots), values) * segment
        sharp = rng.choice(joints, size=min(int(rng.poisson(kinks)), joints), replace=False)
        smooth[sharp] = rng.choice([-1.0, 1.0], size=len(sharp)) * rng.uniform(
            min(0.3, sharpest), sharpest, size=len(sharp))
        return smooth

    return _first_placed(rng, turns, segment, margin, threshold, "a cord shape")


def wavy_cord_shape(
    rng: np.random.Generator,
    *,
    n_points: int = 20,
    length: float = 1.0,
    margin: float = 0.1,
    max_curvature: float = 9.0,
    threshold: float = COSINE_THRESHOLD,
    max_modes: int = 6,
) -> np.ndarray:
    """Draw a smooth cord-like shape whose bends are as often many and strong as few and weak.

    :func:`random_cord_shape` weakens its higher Fourier modes, so a cord that bends both
    ways, or three or four times, is rare in what it draws, and most rarely strongly. Here the
    curvature is a Fourier series over the first ``M`` modes (``M`` uniform in
    ``1..max_modes``: one mode is an arc, two a hook, spiral or S, more a wave), with
    every mode's coefficient standard normal (a flat spectrum) and a random phase, scaled so
    its largest magnitude is ``max_curvature * sqrt(u)``, ``u`` uniform in ``(0, 1)``. Placed
    as ``random_cord_shape`` places.

    Args:
        rng: Source of randomness.
        n_points: Number of points.
        length: Cord length, metres.
        margin: Distance every point keeps from the table edge, metres.
        max_curvature: Largest curvature, 1/m.
        threshold: The cord-like filter the shape must pass, in ``[-1, 1)``.
        max_modes: Most Fourier modes of the curvature, ``>= 1``.

    Returns:
        float32 ``(n_points, 2)``.
    """
    _check_threshold(threshold)
    if isinstance(max_modes, bool) or not (isinstance(max_modes, (int, np.integer))
                                           and max_modes >= 1):
        raise InputError(f"max_modes must be an int >= 1, got {max_modes!r}")
    segment = length / (n_points - 1)
    s = (np.arange(n_points - 2) + 0.5) / (n_points - 2)

    def turns() -> np.ndarray:
        modes = np.arange(int(rng.integers(1, max_modes + 1)))
        coef = rng.normal(size=len(modes))
        phase = rng.uniform(0.0, 2.0 * np.pi, size=len(modes))
        kappa = (coef * np.cos(np.pi * modes * s[:, None] + phase)).sum(axis=1)
        peak = max_curvature * np.sqrt(rng.uniform())
        return kappa * (peak / max(float(np.abs(kappa).max()), 1e-12)) * segment

    return _first_placed(rng, turns, segment, margin, threshold, "a cord shape")


#: Families of :func:`analytic_shape`.
ANALYTIC_KINDS = ("arc", "s-curve", "spiral", "zigzag")


def analytic_shape(
    kind: str,
    rng: np.random.Generator,
    *,
    n_points: int = 20,
    length: float = 1.0,
    margin: float = 0.15,
    max_curvature: float = 9.0,
) -> np.ndarray:
    """A cord shape from an analytic family, at a random pose on the table.

    Unlike :func:`random_cord_shape` (a random Fourier curvature), these are the textbook
    curves a model trained on random data has never seen as such: an ``"arc"`` (constant
    curvature), an ``"s-curve"`` (one sine period of curvature), a ``"spiral"`` (curvature
    growing linearly along the cord) and a ``"zigzag"`` (straight runs joined by sharp
    alternating turns). Every curvature stays within ``max_curvature`` (1/m) and every turn
    passes the cord-like filter, so each shape is within the cord's bending limit.

    Args:
        kind: One of ``ANALYTIC_KINDS``.
        rng: Source of randomness (the family's parameters and the pose).
        n_points: Number of points.
        length: Cord length, metres.
        margin: Distance every point keeps from the table edge, metres.
        max_curvature: Largest curvature, 1/m.

    Returns:
        float32 ``(n_points, 2)``.
    """
    if kind not in ANALYTIC_KINDS:
        raise InputError(f"kind must be one of {ANALYTIC_KINDS}, got {kind!r}")
    segment = length / (n_points - 1)
    s = (np.arange(n_points - 2) + 0.5) / (n_points - 2)  # joint positions, 0..1
    kmax = max_curvature
    sign = rng.choice([-1.0, 1.0])
    if kind == "arc":
        kappa = np.full_like(s, rng.uniform(1.0, 0.8 * kmax))
    elif kind == "s-curve":
        kappa = rng.uniform(2.0, 0.8 * kmax) * np.sin(2 * np.pi * s)
    elif kind == "spiral":
        kappa = rng.uniform(0.0, 1.0) + (rng.uniform(0.6, 1.0) * kmax - 1.0) * s
    else:  # zigzag: sharp turns (up to 70 degrees) every `run` joints, alternating
        run = int(rng.integers(3, 6))
        angle = np.radians(rng.uniform(30.0, 70.0))
        joints = np.arange(n_points - 2)
        turn_at = (joints % run) == run // 2
        turns = np.where(turn_at, angle * (-1.0) ** (joints // run), 0.0)
        kappa = turns / segment
    if kind != "zigzag":  # a zigzag's kinks are single sharp joints, not a curvature
        kappa = np.clip(kappa, -kmax, kmax)
    turns = sign * kappa * segment
    return _first_placed(rng, lambda: turns, segment, margin, None, f"a {kind}")
