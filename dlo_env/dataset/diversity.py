"""How varied a set of shapes is: table coverage, turning angles, distinct shapes.

The same measures are printed by ``dlo collect`` and by ``benchmarks/collect_throughput.py``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dlo_env.errors import InputError
from dlo_env.shapes import TABLE_HALF, turning_cosines

#: Edges of the turning-angle histogram, degrees (the paper's filter allows up to 75.5 deg).
ANGLE_EDGES = (0.0, 5.0, 10.0, 20.0, 30.0, 45.0, 60.0, 75.5, 180.0)


def grid_coverage(shapes: np.ndarray, cells: int = 10, half: float = TABLE_HALF) -> float:
    """Share of the cells of a ``cells x cells`` grid over the table touched by a cord point.

    Args:
        shapes: ``(B, n, 2)`` metres.
        cells: Cells per side of the grid over ``[-half, half]^2``.
        half: Half the side of the table, metres.

    Returns:
        The share in ``[0, 1]``.
    """
    if cells < 1:
        raise InputError(f"cells must be >= 1, got {cells!r}")
    points = np.asarray(shapes, dtype=np.float64).reshape(-1, 2)
    idx = np.floor((points + half) / (2.0 * half) * cells).astype(np.int64)
    idx = idx[((idx >= 0) & (idx < cells)).all(axis=1)]
    touched = np.unique(idx[:, 0] * cells + idx[:, 1])
    return len(touched) / cells**2


def turning_angles(shapes: np.ndarray) -> np.ndarray:
    """Angle between consecutive segments at every inner point, degrees, ``(..., n-2)``."""
    cos = np.clip(turning_cosines(shapes), -1.0, 1.0)
    return np.degrees(np.arccos(cos))


def turning_angle_histogram(
    shapes: np.ndarray, edges: tuple[float, ...] = ANGLE_EDGES
) -> tuple[np.ndarray, np.ndarray]:
    """Histogram of the turning angles of all shapes.

    Returns:
        ``(counts, edges)`` with ``len(counts) == len(edges) - 1``.
    """
    counts, out_edges = np.histogram(turning_angles(shapes).ravel(), bins=np.asarray(edges))
    return counts, out_edges


def distinct_count(shapes: np.ndarray, resolution: float = 0.01) -> int:
    """Number of shapes distinct at ``resolution``: different cells of a grid of that pitch.

    Every coordinate is floored to a multiple of ``resolution``; two shapes are the same when
    all their points fall in the same cells. This counts near duplicates (a cord at rest
    recorded twice) once; shapes a few millimetres apart can still land in different cells.
    """
    if not resolution > 0:
        raise InputError(f"resolution must be > 0, got {resolution!r}")
    arr = np.asarray(shapes, dtype=np.float64)
    if len(arr) == 0:
        return 0
    keys = np.ascontiguousarray(np.floor(arr / resolution).astype(np.int32).reshape(len(arr), -1))
    rows = keys.view(np.dtype((np.void, keys.dtype.itemsize * keys.shape[1]))).ravel()
    return len(np.unique(rows))


@dataclass(frozen=True)
class DiversityReport:
    """Diversity of a set of shapes.

    Attributes:
        num_shapes: Shapes measured.
        grid_coverage: Share of the 10 x 10 grid over the table touched by cord points.
        distinct: Shapes distinct at 1 cm resolution.
        angle_counts: Turning-angle histogram counts.
        angle_edges: Its bin edges, degrees.
    """

    num_shapes: int
    grid_coverage: float
    distinct: int
    angle_counts: np.ndarray
    angle_edges: np.ndarray

    @property
    def distinct_fraction(self) -> float:
        """Share of the shapes distinct at 1 cm."""
        return self.distinct / max(self.num_shapes, 1)

    def lines(self) -> list[str]:
        """A human-readable summary, one string per line."""
        out = [
            f"grid coverage (10x10 over the table): {self.grid_coverage:.0%}",
            f"distinct at 1 cm: {self.distinct} of {self.num_shapes} "
            f"({self.distinct_fraction:.1%})",
            "turning angles (degrees, share of joints):",
        ]
        total = max(int(self.angle_counts.sum()), 1)
        for lo, hi, count in zip(self.angle_edges[:-1], self.angle_edges[1:], self.angle_counts):
            share = count / total
            out.append(f"  {lo:5.1f}-{hi:5.1f}  {share:6.1%}  {'#' * round(40 * share)}")
        return out


def diversity_report(shapes: np.ndarray) -> DiversityReport:
    """Measure grid coverage, distinct shapes at 1 cm and turning angles of ``(B, n, 2)``."""
    counts, edges = turning_angle_histogram(shapes)
    return DiversityReport(
        num_shapes=len(shapes),
        grid_coverage=grid_coverage(shapes),
        distinct=distinct_count(shapes, 0.01),
        angle_counts=counts,
        angle_edges=edges,
    )
