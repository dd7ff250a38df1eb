"""Batched gradient refinement of latents: find the latent whose decoded shape matches a target.

The objective is the success criterion itself, the mean per-point distance in metres. All
targets and all restarts are refined together in one batch, so inverting many shapes costs
about as much as inverting one.
"""

from __future__ import annotations

from collections.abc import Callable

import torch

from latent_model.metrics import error


def refine_latents(
    decode: Callable[[torch.Tensor], torch.Tensor],
    targets: torch.Tensor,
    initial: torch.Tensor,
    low: torch.Tensor,
    high: torch.Tensor,
    steps: int = 100,
    lr: float = 0.05,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Refine ``K`` starting latents per target by Adam on the decoded error; keep the best.

    Args:
        decode: Differentiable map from latents ``(M, L)`` to world shapes ``(M, n, 2)``.
        targets: World shapes ``(B, n, 2)``.
        initial: Starting latents ``(B, K, L)``.
        low: Lower bounds ``(L,)`` of the latent (``-inf`` for free coordinates).
        high: Upper bounds ``(L,)``.
        steps: Adam steps.
        lr: Adam learning rate.

    Returns:
        The best latent per target ``(B, L)`` and its error ``(B,)`` in metres.
    """
    b, k, dim = initial.shape
    flat_targets = targets.repeat_interleave(k, dim=0)  # (B*K, n, 2)
    latent = initial.reshape(b * k, dim).clone().requires_grad_(True)
    optimiser = torch.optim.Adam([latent], lr=lr)
    for _ in range(steps):
        optimiser.zero_grad(set_to_none=True)
        # Sum, not mean: each latent's gradient must not shrink with the batch size.
        error(decode(latent), flat_targets).sum().backward()
        optimiser.step()
        with torch.no_grad():
            latent.copy_(torch.maximum(torch.minimum(latent, high), low))
    with torch.no_grad():
        final = error(decode(latent), flat_targets).view(b, k)  # (B, K)
        best = final.argmin(dim=1)  # (B,)
        chosen = latent.view(b, k, dim)[torch.arange(b), best]
        return chosen.detach(), final[torch.arange(b), best]
