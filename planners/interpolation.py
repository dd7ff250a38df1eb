"""Shape transition by latent interpolation: the paper's straight latent line, decoded."""

from __future__ import annotations

import numpy as np

from dlo_env.errors import InputError
from planners.interfaces import ShapeSurrogate
from planners.observation import as_shape
from planners.surrogate import Surrogate


def interpolate(
    model: ShapeSurrogate,
    start: np.ndarray,
    goal: np.ndarray,
    steps: int = 10,
    *,
    return_latents: bool = False,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Invert ``start`` and ``goal``, take evenly spaced latents between them, decode each.

    The first and last shapes are the decoded inversions of ``start`` and ``goal`` (not the
    inputs themselves): how far they differ from the inputs is the model's inversion error.

    Args:
        model: A shape model (``latent_model.ShapeModel`` or the same interface).
        start: ``(n, 2)`` or flat ``(2n,)`` start shape, metres.
        goal: ``(n, 2)`` or flat ``(2n,)`` goal shape, metres.
        steps: Number of shapes on the path, at least 2.
        return_latents: Also return the latents ``(steps, d)``.

    Returns:
        Shapes ``(steps, n, 2)`` float32, and the latents if ``return_latents``.
    """
    if not isinstance(steps, (int, np.integer)) or steps < 2:
        raise InputError(f"steps must be an int >= 2, got {steps!r}")
    surrogate = Surrogate(model)
    n = surrogate.n_points
    pair = np.stack([as_shape(start, n, "start"), as_shape(goal, n, "goal")])
    z, _, _ = surrogate.invert(pair)
    latents = surrogate.segment(z[:1], z[1:], np.linspace(0.0, 1.0, int(steps)))[0]
    shapes = surrogate.decode(latents)
    return (shapes, latents) if return_latents else shapes
