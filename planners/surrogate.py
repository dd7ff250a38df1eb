"""Numpy access to a shape model (the surrogate) for the planners.

The planners need four things from a model, the :class:`~planners.interfaces.ShapeSurrogate`
protocol: ``n_points``, ``latent_dim``, ``decode(z)`` and ``invert(shapes)``
(``latent_model.ShapeModel`` provides them; so does any toy model with the same methods). This
module converts arrays in and out, counts decoder calls, and draws the points of a straight
latent segment, using the model's own ``interpolate_latents`` when it has one (a latent that
holds an angle may need to wrap), a straight line otherwise.
"""

from __future__ import annotations

import inspect
from typing import Any

import numpy as np

from dlo_env.errors import InputError
from planners.interfaces import ShapeSurrogate


def to_numpy(value: Any) -> np.ndarray:
    """A numpy array from a numpy array, a list, or a torch tensor (detached, on the CPU)."""
    if hasattr(value, "detach"):
        value = value.detach().cpu().numpy()
    return np.asarray(value)


def model_n_points(model: ShapeSurrogate) -> int:
    """Number of points of the shapes ``model`` decodes; ``ValueError`` if it does not say."""
    n = getattr(model, "n_points", None)
    if not isinstance(n, (int, np.integer)) or n < 3:
        raise InputError(
            f"model must have an int attribute n_points >= 3 (a latent_model.ShapeModel), "
            f"got {type(model).__name__} with n_points={n!r}"
        )
    return int(n)


def model_latent_dim(model: ShapeSurrogate) -> int:
    """Dimension of the latents ``model`` decodes; ``ValueError`` if it does not say."""
    d = getattr(model, "latent_dim", None)
    if not isinstance(d, (int, np.integer)) or d < 1:
        raise InputError(
            f"model must have an int attribute latent_dim >= 1 (a latent_model.ShapeModel), "
            f"got {type(model).__name__} with latent_dim={d!r}"
        )
    return int(d)


def _keyword_names(function: Any) -> set[str] | None:
    """Keyword parameters ``function`` accepts (``None``: any, it takes ``**kwargs``)."""
    try:
        parameters = inspect.signature(function).parameters.values()
    except (TypeError, ValueError):  # builtins without a signature: pass nothing extra
        return set()
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters):
        return None
    return {p.name for p in parameters
            if p.kind in (inspect.Parameter.KEYWORD_ONLY, inspect.Parameter.POSITIONAL_OR_KEYWORD)}


class Surrogate:
    """A shape model seen through numpy float32 arrays, with a count of decoder calls.

    Args:
        model: A :class:`~planners.interfaces.ShapeSurrogate`: ``n_points``, ``latent_dim``,
            ``decode(z) -> (B, n, 2)`` and ``invert(shapes) -> (z, err, ok)``.
    """

    def __init__(self, model: ShapeSurrogate) -> None:
        for method in ("decode", "invert"):
            if not callable(getattr(model, method, None)):
                raise InputError(
                    f"model must have a {method}() method (a latent_model.ShapeModel), got "
                    f"{type(model).__name__}"
                )
        self.model = model
        self.n_points = model_n_points(model)
        self.latent_dim = model_latent_dim(model)
        self.decoder_calls = 0
        self._interpolate = getattr(model, "interpolate_latents", None)
        self._invert_options = _keyword_names(model.invert)

    def decode(self, latents: np.ndarray) -> np.ndarray:
        """Shapes ``(..., n, 2)`` of latents ``(..., d)``, in one model call."""
        z = np.asarray(latents, dtype=np.float32)
        lead = z.shape[:-1]
        flat = z.reshape(-1, self.latent_dim)
        if len(flat) == 0:
            return np.zeros(lead + (self.n_points, 2), dtype=np.float32)
        self.decoder_calls += 1
        shapes = to_numpy(self.model.decode(flat)).astype(np.float32, copy=False)
        return shapes.reshape(lead + (self.n_points, 2))

    def invert(
        self, shapes: np.ndarray, **options: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Latents ``(B, d)``, reconstruction errors ``(B,)`` (metres) and verified flags.

        ``options`` whose value is not None go to ``model.invert`` (e.g. ``steps`` and
        ``restarts`` of ``ShapeModel.invert``'s refinement) when it accepts them; a model
        whose ``invert`` has no such option inverts its own way.
        """
        given = {k: v for k, v in options.items()
                 if v is not None and (self._invert_options is None or k in self._invert_options)}
        out = self.model.invert(np.asarray(shapes, dtype=np.float32), **given)
        z, err, ok = (to_numpy(v) for v in out)
        return (
            z.astype(np.float32).reshape(-1, self.latent_dim),
            err.astype(np.float64).reshape(-1),
            ok.astype(bool).reshape(-1),
        )

    def latent_bounds(self) -> tuple[np.ndarray, np.ndarray] | None:
        """``(low, high)`` of the latents the model was trained on, if it says (else None)."""
        low = getattr(self.model, "latent_low", None)
        high = getattr(self.model, "latent_high", None)
        if low is None or high is None:
            return None
        low, high = to_numpy(low).astype(np.float32), to_numpy(high).astype(np.float32)
        if low.shape != (self.latent_dim,) or high.shape != (self.latent_dim,):
            return None
        return low, high

    def segment(self, start: np.ndarray, end: np.ndarray, fractions: np.ndarray) -> np.ndarray:
        """Points of straight latent segments: ``(B, d)``, ``(B, d)``, ``(K,)`` -> ``(B, K, d)``.

        Uses ``model.interpolate_latents(start, end, fractions)`` when the model defines it.
        """
        z0 = np.asarray(start, dtype=np.float32).reshape(-1, self.latent_dim)
        z1 = np.asarray(end, dtype=np.float32).reshape(-1, self.latent_dim)
        t = np.asarray(fractions, dtype=np.float32).reshape(-1)
        if self._interpolate is not None:
            points = to_numpy(self._interpolate(z0, z1, t)).astype(np.float32)
            return points.reshape(len(z0), len(t), self.latent_dim)
        return z0[:, None, :] + t[None, :, None] * (z1 - z0)[:, None, :]
