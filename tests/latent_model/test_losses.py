from __future__ import annotations

import math

import torch

from latent_model.losses import (
    discriminator_loss,
    generator_adversarial_loss,
    reconstruction_loss,
    sliced_wasserstein,
    spacing_loss,
)


def test_spacing_loss_on_a_hand_made_chain():
    # gaps 1, 2 and 0.5 against a rest spacing of 1: (0)^2 + (1)^2 + (0.5)^2 = 1.25
    chain = torch.tensor([[[0.0, 0.0], [1.0, 0.0], [1.0, 2.0], [1.5, 2.0]]])
    assert math.isclose(float(spacing_loss(chain, rest=1.0)), 1.25, rel_tol=1e-6)


def test_spacing_loss_is_zero_for_evenly_spaced_chains_and_averages_over_the_batch():
    even = torch.stack([torch.arange(5.0), torch.zeros(5)], dim=-1)[None]
    stretched = even * 2  # gaps 2: 4 * (1 - 2)^2 = 4
    assert float(spacing_loss(even, rest=1.0)) == 0.0
    assert math.isclose(float(spacing_loss(torch.cat([even, stretched]), rest=1.0)), 2.0)


def test_minimax_losses_at_an_undecided_discriminator():
    zero = torch.zeros(8)
    assert math.isclose(float(discriminator_loss(zero, zero)), 2 * math.log(2), rel_tol=1e-6)
    assert math.isclose(float(generator_adversarial_loss(zero)), math.log(2), rel_tol=1e-6)


def test_reconstruction_loss_sums_squared_coordinates():
    x = torch.zeros(2, 3, 2)
    y = x.clone()
    y[0, 0, 0] = 2.0  # 4 in the first chain, 0 in the second: mean 2
    assert float(reconstruction_loss(x, y)) == 2.0


def test_sliced_wasserstein_is_zero_for_equal_sets_and_grows_with_a_shift():
    g = torch.Generator().manual_seed(0)
    a = torch.rand(512, 5, generator=g) * 2 - 1
    assert float(sliced_wasserstein(a, a.flip(0), generator=g)) < 1e-12
    near = float(sliced_wasserstein(a + 0.1, a, generator=g))
    far = float(sliced_wasserstein(a + 0.5, a, generator=g))
    assert 0 < near < far
