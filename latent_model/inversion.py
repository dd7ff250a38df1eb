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
    tolerance: float = 0.0,
) -> tuple[torch.Tensor, torch.Tensor]:
    """Refine ``K`` starting latents per target by Adam on the decoded error; keep the best.

    The best latent seen is kept for every target (the starting latents included, so the
    result is never worse than the best start), and the refinement stops early once every
    target has a latent within ``tolerance``.

    Args:
        decode: Differentiable map from latents ``(M, L)`` to world shapes ``(M, n, 2)``.
        targets: World shapes ``(B, n, 2)``.
        initial: Starting latents ``(B, K, L)``.
        low: Lower bounds ``(L,)`` of the latent (``-inf`` for free coordinates).
        high: Upper bounds ``(L,)``.
        steps: Most Adam steps.
        lr: Adam learning rate.
        tolerance: Stop when every target is matched this closely, metres (0: run all steps).

    Returns:
        The best latent per target ``(B, L)`` and its error ``(B,)`` in metres.
    """
    b, k, dim = initial.shape
    flat_targets = targets.repeat_interleave(k, dim=0)  # (B*K, n, 2)
    latent = initial.reshape(b * k, dim).clone().requires_grad_(True)
    best = latent.detach().clone()
    best_err = torch.full((b * k,), float("inf"), device=latent.device)
    optimiser = torch.optim.Adam([latent], lr=lr)
    rows = torch.arange(b, device=latent.device)
    with torch.enable_grad():  # the descent needs gradients even under torch.no_grad()
        for step in range(steps + 1):
            errors = error(decode(latent), flat_targets)  # (B*K,) at the current latents
            with torch.no_grad():
                better = errors < best_err
                best_err = torch.where(better, errors, best_err)
                best[better] = latent[better]
                done = best_err.view(b, k).min(dim=1).values <= tolerance
                if step == steps or bool(done.all()):
                    break
            optimiser.zero_grad(set_to_none=True)
            # Sum, not mean: each latent's gradient must not shrink with the batch size.
            errors.sum().backward()
            optimiser.step()
            with torch.no_grad():
                latent.copy_(torch.maximum(torch.minimum(latent, high), low))
    per_target = best_err.view(b, k)  # (B, K)
    choice = per_target.argmin(dim=1)  # (B,)
    return best.view(b, k, dim)[rows, choice], per_target[rows, choice].detach()
