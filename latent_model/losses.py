"""Training losses: the minimax GAN loss (non-saturating generator form) and point spacing."""

from __future__ import annotations

import torch
import torch.nn.functional as F


def discriminator_loss(real_logits: torch.Tensor, fake_logits: torch.Tensor) -> torch.Tensor:
    """The discriminator's side of the minimax game: ``-log D(x) - log(1 - D(G(z)))``, averaged."""
    return F.softplus(-real_logits).mean() + F.softplus(fake_logits).mean()


def generator_adversarial_loss(fake_logits: torch.Tensor) -> torch.Tensor:
    """Non-saturating generator loss ``-log D(G(z))``, averaged.

    Same fixed point as the minimax ``log(1 - D(G(z)))`` but with strong gradients while the
    discriminator still wins easily (Goodfellow et al. 2014, section 3).
    """
    return F.softplus(-fake_logits).mean()


def spacing_loss(points: torch.Tensor, rest: float) -> torch.Tensor:
    """The paper's point-spacing loss ``sum_i (d_r - |g_{i+1} - g_i|)^2``, averaged over the batch.

    Args:
        points: Chains ``(B, n, 2)``.
        rest: ``d_r``, the mean distance between adjacent points in the data, same units.
    """
    gaps = (points[:, 1:] - points[:, :-1]).norm(dim=-1)  # (B, n-1)
    return ((rest - gaps) ** 2).sum(dim=-1).mean()


def reconstruction_loss(shapes: torch.Tensor, reconstructed: torch.Tensor) -> torch.Tensor:
    """The Encoder's ``||x - G(E(x))||^2``, summed over coordinates, averaged over the batch."""
    return ((shapes - reconstructed) ** 2).flatten(1).sum(dim=-1).mean()


def sliced_wasserstein(samples: torch.Tensor, prior: torch.Tensor, projections: int = 32,
                       generator: torch.Generator | None = None) -> torch.Tensor:
    """Squared sliced 1-D Wasserstein-2 distance between two equal-size point sets ``(B, k)``.

    Pulls the Encoder's latents of the data towards the generator's prior, so that sampling
    ``z ~ U[-1, 1]^k`` produces shapes with the data's frequencies (used when
    ``TrainConfig.prior_weight > 0``).
    """
    k = samples.shape[-1]
    directions = torch.randn(k, projections, generator=generator, device=samples.device)
    directions = directions / directions.norm(dim=0, keepdim=True)
    a = torch.sort(samples @ directions, dim=0).values  # (B, P)
    b = torch.sort(prior @ directions, dim=0).values
    return ((a - b) ** 2).mean()
