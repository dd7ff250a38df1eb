"""Projecting predicted shapes onto inextensible cords: every segment at its rest length.

The simulated cord's links are rigid, so every shape it rests in has equal segments. A learned
prediction does not by construction; where it hesitates between two outcomes (a loop that may
swing either way) its mean is shorter than the cord. :func:`make_inextensible` moves the points
to a nearby shape with rest-length segments the way position-based dynamics does: each segment
in turn is set to its rest length by moving its two points along it, a held end not at all,
over-relaxed (each move 1.8 times the one that would fix the segment alone) to converge faster.
Distances only, so it turns and shifts with the shape (the model stays equivariant), and it is
symmetric under reversing the cord when the number of segments is odd (the default 19).
"""

from __future__ import annotations

import numpy as np

#: Sweeps over all segments, and the over-relaxation of each correction. Tuned on the training
#: transitions with the shipped model: 20 sweeps at 1.8 give the error of 80 plain sweeps
#: (one move: head 0.221 -> 0.207 cm, both ends 0.686 -> 0.618 cm; 20 plain sweeps: 0.212, 0.629).
ITERATIONS = 20
OVER_RELAXATION = 1.8


def make_inextensible(points: np.ndarray, rest: float, pin_first: np.ndarray,
                      pin_last: np.ndarray, iterations: int = ITERATIONS,
                      over_relaxation: float = OVER_RELAXATION) -> np.ndarray:
    """``points`` ``(B, n, 2)`` moved towards segments of length ``rest``.

    Args:
        points: The shapes.
        rest: Rest length of a segment.
        pin_first, pin_last: ``(B,)`` bool, the first / last point is held (does not move).
        iterations: Sweeps; each sets the even, then the odd segments to length.
        over_relaxation: Factor on every correction (1: plain; below 2 converges).

    Returns:
        float32 ``(B, n, 2)``, a new array; the held points are unchanged.
    """
    # Coordinates as (n, B) rows: every segment slice below is whole contiguous rows, and the
    # length is sqrt(dx^2 + dy^2) (np.abs of complex numbers, hypot, is slower).
    p = np.asarray(points, dtype=np.float32)
    x, y = np.ascontiguousarray(p[..., 0].T), np.ascontiguousarray(p[..., 1].T)
    n = x.shape[0]
    free = np.ones(x.shape, dtype=np.float32)
    free[0] = ~np.asarray(pin_first, dtype=bool)
    free[-1] = ~np.asarray(pin_last, dtype=bool)
    shares = []
    for parity in (0, 1):
        wa, wb = free[parity:n - 1:2], free[parity + 1:n:2]
        total = np.maximum(wa + wb, 1e-12)
        shares.append((over_relaxation * wa / total, over_relaxation * wb / total))
    rest = np.float32(rest)
    for _ in range(iterations):
        for parity, (share_a, share_b) in enumerate(shares):
            xa, xb = x[parity:n - 1:2], x[parity + 1:n:2]  # views: updated in place
            ya, yb = y[parity:n - 1:2], y[parity + 1:n:2]
            dx, dy = xb - xa, yb - ya
            length = dx * dx
            length += dy * dy
            np.sqrt(length, out=length)
            np.maximum(length, 1e-12, out=length)
            fix = length - rest
            fix /= length  # the share of the segment that is too long
            dx *= fix
            dy *= fix
            xa += share_a * dx
            ya += share_a * dy
            xb -= share_b * dx
            yb -= share_b * dy
    out = np.empty(p.shape, dtype=np.float32)
    out[..., 0], out[..., 1] = x.T, y.T
    return out
