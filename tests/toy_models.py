"""Toy shape models with the ``ShapeModel`` interface, for tests that must not need a checkpoint."""

from __future__ import annotations

import numpy as np

from dlo_env.shapes import error


class ToyHeadModel:
    """A two-dimensional latent that places a straight, horizontal cord.

    ``z = (u, v)`` in ``[-1, 1]^2`` puts the head at ``(-0.5 + 0.4 u, 0.5 v + 0.3 u^2 - 0.15)``
    and the cord points along +x from it. A straight latent line in ``u`` moves the head along a
    parabola, so only short latent edges move it along a straight line: the tree planner's
    straightness check has something to reject.
    """

    latent_dim = 2

    def __init__(self, n_points: int = 20, length: float = 1.0) -> None:
        self.n_points = n_points
        self.length = length
        self.offsets = np.stack(
            [np.linspace(0.0, length, n_points), np.zeros(n_points)], axis=1
        ).astype(np.float32)

    def head(self, z: np.ndarray) -> np.ndarray:
        z = np.asarray(z, dtype=np.float64)
        u, v = z[..., 0], z[..., 1]
        return np.stack([-0.5 + 0.4 * u, 0.5 * v + 0.3 * u**2 - 0.15], axis=-1)

    def decode(self, z: np.ndarray) -> np.ndarray:
        z = np.asarray(z, dtype=np.float32).reshape(-1, 2)
        return (self.head(z)[:, None, :] + self.offsets).astype(np.float32)

    def encode(self, shapes: np.ndarray) -> np.ndarray:
        head = np.asarray(shapes, dtype=np.float64).reshape(-1, self.n_points, 2)[:, 0]
        u = np.clip((head[:, 0] + 0.5) / 0.4, -1.0, 1.0)
        v = np.clip((head[:, 1] - 0.3 * u**2 + 0.15) / 0.5, -1.0, 1.0)
        return np.stack([u, v], axis=1).astype(np.float32)

    def invert(self, shapes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        shapes = np.asarray(shapes, dtype=np.float32).reshape(-1, self.n_points, 2)
        z = self.encode(shapes)
        err = np.asarray(error(self.decode(z), shapes)).reshape(-1)
        return z, err, err <= 0.01
