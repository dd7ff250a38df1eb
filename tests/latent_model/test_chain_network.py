"""The chain-local transition network (latent_model.chain_network)."""

from __future__ import annotations

import pytest
import torch

from latent_model.chain_network import EnsembleChainNet
from latent_model.transition_model import TransitionModel, TransitionModelConfig


def _net(depth: int = 3, members: int = 3) -> EnsembleChainNet:
    torch.manual_seed(0)
    net = EnsembleChainNet(members, n_points=20, rim_targets=2, rim_blocks=1, width=8,
                           depth=depth)
    with torch.no_grad():  # a head of full size, so that every output depends on its inputs
        net.head[0].mul_(10.0)
    return net


def test_members_run_together_alone_and_as_copies():
    net = _net()
    x = torch.randn(5, net.inputs)
    together = net(x)
    assert together.shape == (3, 5, 40)
    for i in range(3):
        assert torch.allclose(net.member(x, i), together[i], atol=1e-6)
    assert torch.allclose(net(x, members=2), together[:2], atol=1e-6)
    assert torch.allclose(net.first(2)(x), together[:2], atol=1e-6)
    per_member = torch.randn(3, 5, net.inputs)
    assert torch.allclose(net(per_member)[1], net.member(per_member[1], 1), atol=1e-6)


def test_a_point_sees_only_its_receptive_field_along_the_chain():
    net = _net(depth=3)  # dilations 1, 2, 4: 7 points on either side
    assert net.reach == 7 and _net(depth=7).reach == 22
    x = torch.randn(1, net.inputs)
    moved = x.clone()
    moved[0, 0:2] += 1.0  # the first point's position
    diff = (net(moved) - net(x))[0].reshape(20, 2).abs().sum(dim=-1)
    assert (diff[:8] > 0).all()
    assert (diff[8:] == 0).all()
    glob = x.clone()
    glob[0, -2] += 1.0  # a global feature (the other end's move) reaches every point
    assert ((net(glob) - net(x))[0].reshape(20, 2).abs().sum(dim=-1) > 0).all()


def test_the_model_builds_a_chain_ensemble_with_an_mlp_mean_network():
    config = TransitionModelConfig(architecture="chain", width=8, depth=2, members=2,
                                   mean_network=True, contact_reach=0.03)
    model = TransitionModel(config, device="cpu")
    assert isinstance(model.net, EnsembleChainNet) and model.net.rim_blocks == 2
    assert model.net.inputs == config.inputs
    assert type(model.mean_net).__name__ == "EnsembleMLP"
    with pytest.raises(ValueError, match="architecture must be one of"):
        TransitionModelConfig(architecture="transformer")
    with pytest.raises(ValueError, match="does not grow new inputs"):
        model.net.with_inputs(0, 2)
