from __future__ import annotations

import math

import numpy as np
import torch

from latent_model.pose import (
    canonical_pose,
    canonicalise,
    latent_to_pose,
    pose_to_latent,
    to_canonical,
    to_world,
)


def straight(n: int = 20, angle: float = 0.0, centre=(0.0, 0.0)) -> torch.Tensor:
    s = torch.linspace(-0.5, 0.5, n, dtype=torch.float64)
    d = torch.tensor([math.cos(angle), math.sin(angle)], dtype=torch.float64)
    return (s[:, None] * d + torch.tensor(centre, dtype=torch.float64))[None]


def test_pose_of_a_straight_cord_is_its_midpoint_and_head_to_tail_direction():
    centre, angle = canonical_pose(straight(angle=2.0, centre=(0.3, -0.4)))
    assert torch.allclose(centre, torch.tensor([[0.3, -0.4]], dtype=torch.float64))
    assert math.isclose(float(angle), 2.0, abs_tol=1e-9)


def test_canonical_shape_is_centred_and_points_along_x(cord_shapes):
    canon = canonicalise(torch.from_numpy(cord_shapes).double())
    centre, angle = canonical_pose(canon)
    assert centre.abs().max() < 1e-9
    assert angle.abs().max() < 1e-9


def test_canonical_shape_does_not_depend_on_where_the_cord_lies(cord_shapes):
    x = torch.from_numpy(cord_shapes[:10]).double()
    moved = to_world(x, torch.tensor([0.2, -0.1], dtype=torch.float64).expand(10, 2),
                     torch.full((10,), 1.3, dtype=torch.float64))
    assert torch.allclose(canonicalise(x), canonicalise(moved), atol=1e-9)


def test_to_world_inverts_to_canonical(cord_shapes):
    x = torch.from_numpy(cord_shapes[:10]).double()
    centre, angle = canonical_pose(x)
    assert torch.allclose(to_world(to_canonical(x, centre, angle), centre, angle), x, atol=1e-12)


def test_latent_interpolation_of_the_angle_wraps_the_short_way():
    a = pose_to_latent(torch.zeros(1, 2), torch.tensor([math.radians(170.0)]))
    b = pose_to_latent(torch.zeros(1, 2), torch.tensor([math.radians(-170.0)]))
    mids = [latent_to_pose((1 - t) * a + t * b)[1] for t in np.linspace(0, 1, 11)]
    degrees = np.degrees(np.unwrap([float(m) for m in mids]))
    assert np.all(np.diff(degrees) > 0)  # turns monotonically...
    assert math.isclose(degrees[-1] - degrees[0], 20.0, abs_tol=1e-3)  # ...by 20, not 340 degrees
