"""Specification of the dataset diversity measures (dlo_env.dataset.diversity)."""

from __future__ import annotations

import numpy as np
import pytest

from dlo_env.dataset.diversity import (
    distinct_count,
    diversity_report,
    grid_coverage,
    turning_angle_histogram,
    turning_angles,
)
from dlo_env.shapes import random_cord_shape


def straight(y: float, x0: float = -0.5) -> np.ndarray:
    """A straight 1 m cord along x at height ``y`` starting at ``x0``."""
    x = x0 + np.linspace(0.0, 1.0, 20)
    return np.stack([x, np.full(20, y)], axis=1).astype(np.float32)


def test_grid_coverage_counts_cells_touched_by_points():
    # cells are 0.2 m wide: x from -0.5 to 0.5 touches columns 2 to 7 of one row
    assert grid_coverage(straight(0.1)[None]) == pytest.approx(6 / 100)
    assert grid_coverage(np.stack([straight(0.1), straight(-0.9)])) == pytest.approx(12 / 100)


def test_random_shapes_cover_most_of_the_table():
    rng = np.random.default_rng(0)
    shapes = np.array([random_cord_shape(rng) for _ in range(300)])
    assert grid_coverage(shapes) >= 0.9


def test_turning_angles_of_a_right_angle_and_a_straight_cord():
    bent = np.array([[0, 0], [1, 0], [1, 1]], dtype=np.float32)
    np.testing.assert_allclose(turning_angles(bent), [90.0])
    np.testing.assert_allclose(turning_angles(straight(0.0)), 0.0, atol=1e-3)


def test_turning_angle_histogram_counts_every_joint():
    counts, edges = turning_angle_histogram(np.stack([straight(0.0), straight(0.5)]))
    assert counts.sum() == 2 * 18
    assert counts[0] == 36 and edges[0] == 0.0


def test_distinct_count_merges_shapes_in_the_same_1cm_cells_only():
    # points at the centres of 1 cm cells, so a 2 mm shift stays in the same cells
    base = (np.stack([np.arange(20) * 5, np.full(20, 10)], axis=1) * 0.01 + 0.005)
    near = base + 0.002
    far = base + np.array([0.03, 0.0], dtype=np.float32)
    assert distinct_count(np.stack([base, near, far]), 0.01) == 2
    assert distinct_count(np.stack([base, near]), 0.001) == 2


def test_report_prints_coverage_distinct_share_and_histogram():
    report = diversity_report(np.stack([straight(0.1), straight(0.1), straight(0.5)]))
    assert report.distinct == 2 and report.distinct_fraction == pytest.approx(2 / 3)
    text = "\n".join(report.lines())
    assert "grid coverage" in text and "distinct at 1 cm: 2 of 3" in text
    assert "turning angles" in text
