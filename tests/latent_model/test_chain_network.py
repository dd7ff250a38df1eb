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


def test_a_chain_model_reads_the_peg_vectors_per_point_and_trains_around_pegs(tmp_path):
    from dlo_env.dataset.transitions import TransitionCollectConfig, collect_transition_chunk
    from latent_model.transition_training import TransitionTrainConfig, train_transition_model

    config = TransitionModelConfig(architecture="chain", width=8, depth=2, members=2,
                                   contact_reach=0.03, peg_reach=0.1)
    model = TransitionModel(config, device="cpu")
    assert model.net.rim_blocks == 3 and model.net.inputs == config.inputs
    # The flat input's peg vector of point j is point j's third vector block (after its
    # position, the segments on either side, its rim and contact vectors).
    j, x = 7, torch.zeros(1, 1, config.inputs)
    x[0, 0, config.peg_at + 2 * j + 1] = 1.0
    per_point = model.net._unflatten(x)[0, 0]  # (n, features)
    hot = torch.nonzero(per_point[:, :model.net.point_features - 1])  # less where it lies
    assert hot.tolist() == [[j, 2 + 4 + 2 * 2 + 1]]  # the y of its third vector
    shape = torch.stack([torch.linspace(-0.4, 0.4, 20), torch.zeros(20)], 1).numpy()
    move = torch.tensor([0.2, 0.1]).numpy()
    with torch.no_grad():
        model.net.head[0].mul_(10.0)  # outputs that depend on every input
    far = model.predict(shape, "head", move, pegs=[[0.8, 0.8]], inextensible=False)
    empty = model.predict(shape, "head", move, inextensible=False)
    near = model.predict(shape, "head", move, pegs=[[0.0, 0.04]], inextensible=False)
    assert abs(far - empty).max() < 1e-6  # a peg beyond peg_reach is no peg
    assert abs(near - empty).max() > 1e-4  # the points near a peg see it
    data = collect_transition_chunk(TransitionCollectConfig(seed=5, max_pegs=2), 0, 30)
    trained = train_transition_model(
        data, tmp_path / "m", TransitionTrainConfig(steps=2, batch_size=16, eval_every=2), config)
    loaded = TransitionModel.load(tmp_path / "m")
    assert loaded.config.architecture == "chain" and loaded.config.peg_reach == 0.1
    i = int(torch.tensor(data.peg_count).nonzero()[0])
    name = ("head", "tail", "both")[int(data.grasp[i])]
    args = (data.start[i], name, data.end_displacement(torch.tensor([i]).numpy())[0])
    assert abs(loaded.predict(*args, pegs=data.peg_list(i))
               - trained.predict(*args, pegs=data.peg_list(i))).max() < 1e-3
