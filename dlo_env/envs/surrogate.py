"""Entry points of the surrogate environments, which step the learned cord (needs torch).

``dlo_env`` itself depends on numpy, gymnasium and pymunk only; the surrogate environments
live in :mod:`latent_model.surrogate_env` and are registered here by name, so ``gym.make``
finds them after ``import dlo_env`` and says in one line what to install when torch is missing.
"""

from __future__ import annotations

try:
    from latent_model.surrogate_env import (
        DLODualEndpointSurrogateEnv,
        DLODualEndpointSurrogateVectorEnv,
        DLOEndpointSurrogateEnv,
        DLOEndpointSurrogateVectorEnv,
    )
except ModuleNotFoundError as exc:  # pragma: no cover - the core install has no torch
    raise ModuleNotFoundError(
        f"the surrogate environments need the learned model ({exc.name} is missing): "
        "pip install 'dlo[model]'"
    ) from None

__all__ = [
    "DLODualEndpointSurrogateEnv",
    "DLODualEndpointSurrogateVectorEnv",
    "DLOEndpointSurrogateEnv",
    "DLOEndpointSurrogateVectorEnv",
]
