"""The Generator, Discriminator and Encoder (fully connected DCGAN family).

Every module takes the ``ModelConfig``. Shapes inside the networks are in network units
(``latent_model.normalisation``); the generator ends in tanh, so its output lies in
``[-1, 1]``. The discriminator is spectral-normalised on every layer and has no batch norm.
"""

from __future__ import annotations

import torch
from torch import nn
from torch.nn.utils.parametrizations import spectral_norm

from latent_model.config import ModelConfig
from latent_model.normalisation import CANONICAL_SCALE
from latent_model.pose import canonicalise


def _mlp(sizes: list[int], slope: float, spectral: bool) -> nn.Sequential:
    """Linear layers with LeakyReLU between them (none after the last)."""
    layers: list[nn.Module] = []
    for i, (a, b) in enumerate(zip(sizes[:-1], sizes[1:])):
        linear = nn.Linear(a, b)
        layers.append(spectral_norm(linear) if spectral else linear)
        if i < len(sizes) - 2:
            layers.append(nn.LeakyReLU(slope))
    return nn.Sequential(*layers)


class Generator(nn.Module):
    """``G(z)``: a latent ``(B, latent_dim)`` in ``[-1, 1]`` to a chain ``(B, n, 2)``.

    With ``output="points"`` the chain is a tanh layer in ``[-1, 1]``. With ``output="angles"``
    the network gives turning angles and the chain is built from segments of the rest length
    (in network units, ``segment_units``) and moved into its canonical frame.
    """

    def __init__(self, config: ModelConfig, segment_units: float | None = None) -> None:
        super().__init__()
        self.config = config
        n = config.n_points
        out = 2 * n if config.output == "points" else n - 2
        sizes = [config.latent_dim] + [config.width] * config.depth + [out]
        self.net = _mlp(sizes, config.leaky_slope, spectral=False)
        if segment_units is None:
            segment_units = 1.0 / (CANONICAL_SCALE * (n - 1))
        self.segment_units = float(segment_units)

    def forward(self, z: torch.Tensor) -> torch.Tensor:
        if self.config.output == "points":
            out = torch.tanh(self.net(z))  # (B, 2n)
            return out.view(-1, self.config.n_points, 2)  # (B, n, 2)
        turns = torch.pi * torch.tanh(self.net(z))  # (B, n-2)
        headings = torch.cat([turns.new_zeros(turns.shape[0], 1), turns.cumsum(dim=-1)], dim=-1)
        steps = self.segment_units * torch.stack([headings.cos(), headings.sin()], dim=-1)
        chain = torch.cat([steps.new_zeros(steps.shape[0], 1, 2), steps.cumsum(dim=1)], dim=1)
        return canonicalise(chain)  # (B, n, 2)


class Discriminator(nn.Module):
    """``D(x)``: a chain ``(B, n, 2)`` to one real-vs-generated logit ``(B,)``."""

    def __init__(self, config: ModelConfig) -> None:
        super().__init__()
        self.config = config
        sizes = [2 * config.n_points] + [config.width] * config.depth + [1]
        self.net = _mlp(sizes, config.leaky_slope, spectral=True)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.net(x.flatten(1)).squeeze(-1)  # (B,)


class Encoder(nn.Module):
    """``E(x)``: the discriminator's body with a ``latent_dim`` tanh head.

    ``(B, n, 2) -> (B, latent_dim)``.
    """

    def __init__(self, config: ModelConfig) -> None:
        super().__init__()
        self.config = config
        sizes = [2 * config.n_points] + [config.width] * config.depth + [config.latent_dim]
        self.net = _mlp(sizes, config.leaky_slope, spectral=config.encoder_spectral_norm)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return torch.tanh(self.net(x.flatten(1)))  # (B, latent_dim)
