from __future__ import annotations

import pytest
import torch
from torch import nn

from latent_model.config import ModelConfig
from latent_model.networks import Discriminator, Encoder, Generator


def test_generator_maps_latents_to_chains_inside_tanh_range(tiny_config):
    g = Generator(tiny_config)
    out = g(torch.rand(7, 5) * 2 - 1)
    assert out.shape == (7, 20, 2)
    assert out.abs().max() < 1.0


def test_discriminator_gives_one_logit_per_chain(tiny_config):
    assert Discriminator(tiny_config)(torch.randn(7, 20, 2)).shape == (7,)


def test_encoder_maps_chains_to_latents_inside_the_box(tiny_config):
    z = Encoder(tiny_config)(torch.randn(7, 20, 2) * 5)
    assert z.shape == (7, 5)
    assert z.abs().max() <= 1.0


def test_every_discriminator_layer_is_spectrally_normalised_and_there_is_no_batch_norm(tiny_config):
    d = Discriminator(tiny_config)
    linears = [m for m in d.modules() if isinstance(m, nn.Linear)]
    assert len(linears) == tiny_config.depth + 1
    assert all(hasattr(m, "parametrizations") and "weight" in m.parametrizations for m in linears)
    assert not any(isinstance(m, nn.modules.batchnorm._BatchNorm) for m in d.modules())
    assert any(isinstance(m, nn.LeakyReLU) for m in d.modules())


def test_spectral_norm_bounds_each_discriminator_layer():
    d = Discriminator(ModelConfig(width=16, depth=2))
    d.train()
    for _ in range(30):  # power iterations converge during forward passes in train mode
        d(torch.randn(4, 20, 2))
    for m in d.modules():
        if isinstance(m, nn.Linear):
            assert torch.linalg.matrix_norm(m.weight, ord=2) <= 1.05


def test_config_rejects_unknown_representation():
    with pytest.raises(ValueError, match="representation"):
        ModelConfig(representation="polar")


def test_full_latent_adds_the_pose_only_for_the_canonical_representation():
    assert ModelConfig(representation="canonical").full_latent_dim == 5 + 4
    assert ModelConfig(representation="world").full_latent_dim == 5


def test_angle_output_builds_inextensible_chains_in_their_canonical_frame():
    from latent_model.metrics import cord_length, spacing_cv
    from latent_model.normalisation import CANONICAL_SCALE
    from latent_model.pose import canonical_pose

    g = Generator(ModelConfig(width=32, depth=2, output="angles"))
    with torch.no_grad():
        chains = g(torch.rand(16, 5) * 2 - 1) * CANONICAL_SCALE  # metres, 1 m cord
    assert chains.shape == (16, 20, 2)
    assert torch.allclose(cord_length(chains), torch.ones(16), atol=1e-5)
    assert float(spacing_cv(chains).max()) < 1e-5
    centre, angle = canonical_pose(chains)
    assert float(centre.abs().max()) < 1e-5 and float(angle.abs().max()) < 1e-4


def test_angle_output_needs_the_canonical_representation():
    with pytest.raises(ValueError, match="output='angles' needs representation='canonical'"):
        ModelConfig(representation="world", output="angles")
    with pytest.raises(ValueError, match="output must be one of"):
        ModelConfig(output="splines")
