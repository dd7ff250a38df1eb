"""Deprecated location of :class:`dlo_env.core.ray_backend.RayBackend` (the documented import
path of 0.2.0), kept so that ``from dlo_env.dataset.ray_backend import RayBackend`` works."""

from __future__ import annotations

from dlo_env.core.ray_backend import RayBackend

__all__ = ["RayBackend"]
