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
    """``G(z)``: a latent ``(B, latent_dim)`` in ``[-1, 1]`` to a chain ``(B, n, 2)`` in [-1, 1]."""

    def __init__(self, config: ModelConfig) -> None:
        super().__init__()
        self.config = config
        sizes = [config.latent_dim] + [config.width] * config.depth + [2 * config.n_points]
        self.net = _mlp(sizes, config.leaky_slope, spectral=False)

    def forward(self, z: torch.Tensor) -> torch.Tensor:
        out = torch.tanh(self.net(z))  # (B, 2n)
        return out.view(-1, self.config.n_points, 2)  # (B, n, 2)


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


def count_parameters(module: nn.Module) -> int:
    """Number of trainable parameters."""
    return sum(p.numel() for p in module.parameters() if p.requires_grad)
