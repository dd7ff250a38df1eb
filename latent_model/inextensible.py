"""Projecting predicted shapes onto inextensible cords: every segment at its rest length.

The simulated cord's links are rigid, so every shape it rests in has equal segments. A learned
prediction does not by construction; where it hesitates between two outcomes (a loop that may
swing either way) its mean is shorter than the cord. :func:`make_inextensible` moves the points
to a nearby shape with rest-length segments, a held end not at all, by fast projection
(Goldenthal et al., "Efficient simulation of inextensible cloth", 2007): each iteration
linearises the segment lengths and takes the smallest move of the free points that sets them
all at once (a Gauss-Newton step), one tridiagonal solve per shape (the chain's constraints
couple neighbours only). A step moves no point farther than half a segment: where the cord is
held at both ends, slack and nearly straight, the linearised lengths barely depend on moves
across the cord and the full step would be far too long. Distances only, so it turns and
shifts with the shape (the model stays equivariant), and it is symmetric under reversing the
cord. With both ends held farther apart than the cord's length there is no such shape; the
segments then stay stretched (``predict``'s grippers never hold the ends that far apart).
"""

from __future__ import annotations

import numpy as np

#: Iterations, the longest move of a point in one (in segment rest lengths), and the damping
#: added to the solve's diagonal (whose entries are 0-2: 0 for a segment between two held
#: points): it keeps a step finite where the constraints are dependent (a straight cord held at
#: both ends). Chosen on the seed-4 selection file with the shipped model's ``predict`` (one
#: move, mean error over points, misses over 1 cm), head / tail / both: 0.089 / 0.076 / 0.258
#: cm, 12 / 7 / 94 misses with the 20 over-relaxed sweeps of position-based dynamics this
#: replaced; 0.089 / 0.076 / 0.252 cm, 12 / 7 / 90 with these settings, in about half their
#: time. Without the cap (4 iterations) both ends were 0.250 cm, but slack, nearly straight
#: cords held at both ends came out with segments up to 9 times their rest length.
ITERATIONS = 6
MAX_MOVE = 0.5
DAMPING = 1e-4


def make_inextensible(points: np.ndarray, rest: float | np.ndarray, pin_first: np.ndarray,
                      pin_last: np.ndarray, iterations: int = ITERATIONS) -> np.ndarray:
    """``points`` ``(B, n, 2)`` moved to nearby shapes with segments of length ``rest``.

    Args:
        points: The shapes.
        rest: Rest length of a segment: one for every shape, or ``(B,)``.
        pin_first, pin_last: ``(B,)`` bool, the first / last point is held (does not move).
        iterations: Linearise-and-solve steps.

    Returns:
        float32 ``(B, n, 2)``, a new array; the held points are unchanged.
    """
    # Coordinates as (n, B) rows, so every step below is a few whole-row operations; the
    # Thomas algorithm walks the n - 1 segments in order, all shapes at once.
    p = np.asarray(points, dtype=np.float32)
    x, y = np.ascontiguousarray(p[..., 0].T), np.ascontiguousarray(p[..., 1].T)
    n, b = x.shape
    if n < 2:
        return p.copy()
    free = np.ones((n, b), dtype=np.float32)
    free[0] = ~np.asarray(pin_first, dtype=bool)
    free[-1] = ~np.asarray(pin_last, dtype=bool)
    # The solve's matrix J W J^T: diagonal w_i + w_(i+1), off-diagonal -w_(i+1) u_i . u_(i+1)
    # (w_(i+1) = 1: only the end points can be held).
    diag = free[:-1] + free[1:] + np.float32(DAMPING)
    rest = np.asarray(rest, dtype=np.float32)  # () or (B,): broadcasts along the shapes
    longest = np.float32(MAX_MOVE) * rest
    m = n - 1
    ratio = np.empty((m, b), dtype=np.float32)
    lam = np.empty((m, b), dtype=np.float32)
    dx, dy = np.empty((n, b), dtype=np.float32), np.empty((n, b), dtype=np.float32)
    for _ in range(iterations):
        ex, ey = x[1:] - x[:-1], y[1:] - y[:-1]
        length = np.sqrt(ex * ex + ey * ey)
        np.maximum(length, 1e-12, out=length)
        ex /= length  # the segments' directions
        ey /= length
        length -= rest  # how much too long each segment is
        off = -(ex[:-1] * ex[1:] + ey[:-1] * ey[1:])
        pivot = diag[0]
        lam[0] = length[0] / pivot
        for i in range(1, m):
            ratio[i - 1] = off[i - 1] / pivot
            pivot = diag[i] - off[i - 1] * ratio[i - 1]
            lam[i] = (length[i] - off[i - 1] * lam[i - 1]) / pivot
        for i in range(m - 2, -1, -1):
            lam[i] -= ratio[i] * lam[i + 1]
        ex *= lam  # each segment pulls its two points together by this
        ey *= lam
        dx[-1] = dy[-1] = 0.0
        dx[:-1], dy[:-1] = ex, ey
        dx[1:] -= ex
        dy[1:] -= ey
        dx *= free
        dy *= free
        step = np.sqrt((dx * dx + dy * dy).max(axis=0))
        np.maximum(step, longest, out=step)
        scale = longest / step  # 1, or less for a step that would move a point too far
        x += dx * scale
        y += dy * scale
    out = np.empty(p.shape, dtype=np.float32)
    out[..., 0], out[..., 1] = x.T, y.T
    return out
