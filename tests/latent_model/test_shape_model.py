from __future__ import annotations

import numpy as np
import pytest
import torch

from latent_model.checkpoint import FORMAT, FORMAT_VERSION
from latent_model.config import ModelConfig
from latent_model.shape_model import DECODE_CHUNK, ShapeModel
from latent_model.training import normalisation_for


@pytest.fixture
def model(tiny_config) -> ShapeModel:
    torch.manual_seed(0)
    return ShapeModel(tiny_config, normalisation_for(tiny_config), device="cpu")


def test_decode_gives_world_shapes_at_the_pose_in_the_latent(model):
    z = model.sample_latent(6, seed=0)
    shapes = model.decode(z)
    assert shapes.shape == (6, 20, 2) and shapes.dtype == np.float32
    # The pose part [centre, cos, sin] places the shape: its centroid is close to the centre
    # (the untrained generator's output is not exactly centred, so allow its offset).
    offset = np.linalg.norm(shapes.mean(axis=1) - z[:, 5:7], axis=1)
    assert offset.max() < 0.6


def test_decode_in_chunks_equals_one_batch_and_accepts_no_latents(model):
    z = model.sample_latent(DECODE_CHUNK + 7, seed=2)
    whole = model.decode_torch(torch.from_numpy(z)).detach().numpy()
    np.testing.assert_allclose(model.decode(z), whole, atol=1e-6)
    assert model.decode(z[:0]).shape == (0, 20, 2)


def test_inversion_refines_also_under_no_grad(model):
    shapes = model.sample(8, seed=4)
    _, plain, _ = model.invert(shapes, restarts=2, steps=20, tolerance=0.0)
    with torch.no_grad():  # a caller's no_grad (evaluation code) must not disable the refinement
        _, inside, _ = model.invert(shapes, restarts=2, steps=20, tolerance=0.0)
    _, encoder_only, _ = model.invert(shapes, refine=False)
    np.testing.assert_allclose(inside, plain, rtol=1e-5, atol=1e-7)
    assert inside.mean() < encoder_only.mean()


def test_single_latents_and_shapes_give_unbatched_results(model):
    z = model.sample_latent(1, seed=1)[0]
    shape = model.decode(z)
    assert shape.shape == (20, 2)
    assert model.encode(shape).shape == (model.latent_dim,)
    z2, err, ok = model.invert(shape, steps=2)
    assert z2.shape == (model.latent_dim,) and np.ndim(err) == 0 and np.ndim(ok) == 0


def test_sample_is_reproducible_and_lies_on_the_table(model):
    a, b = model.sample(50, seed=3), model.sample(50, seed=3)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, model.sample(50, seed=4))
    assert np.abs(a).max() <= 1.0


def test_inversion_of_decoded_shapes_succeeds(model):
    targets = model.sample(8, seed=5)
    z, err, ok = model.invert(targets, restarts=6, steps=300, lr=0.05)
    assert ok.all(), err
    assert np.allclose(model.decode(z), targets, atol=0.05)
    _, err_encoder, _ = model.invert(targets, refine=False)
    assert (err <= err_encoder + 1e-7).all()  # refinement never makes the encoder guess worse


def test_world_representation_latent_is_just_z():
    config = ModelConfig(width=16, depth=1, representation="world")
    model = ShapeModel(config, normalisation_for(config), device="cpu")
    assert model.latent_dim == 5
    assert model.decode(np.zeros((2, 5))).shape == (2, 20, 2)


def test_load_or_pretrained_loads_the_given_file_else_the_shipped_model(model, tmp_path):
    model.save(tmp_path / "model.pt")
    z = model.sample_latent(2, seed=0)
    given = ShapeModel.load_or_pretrained(tmp_path, device="cpu")
    np.testing.assert_array_equal(given.decode(z), model.decode(z))
    shipped = ShapeModel.load_pretrained(device="cpu")
    for default in (None, ""):
        loaded = ShapeModel.load_or_pretrained(default, device="cpu")
        assert loaded.config == shipped.config
        zs = shipped.sample_latent(2, seed=0)
        np.testing.assert_array_equal(loaded.decode(zs), shipped.decode(zs))


def test_save_and_load_round_trip(model, tmp_path):
    path = model.save(tmp_path / "m.pt")
    loaded = ShapeModel.load(path, device="cpu")
    z = model.sample_latent(4, seed=0)
    assert np.array_equal(loaded.decode(z), model.decode(z))
    assert loaded.config == model.config and loaded.normalisation == model.normalisation
    assert np.array_equal(loaded.encode(model.decode(z)), model.encode(model.decode(z)))


def test_load_accepts_a_training_folder(model, tmp_path):
    model.save(tmp_path)
    assert (tmp_path / "model.pt").is_file()
    assert ShapeModel.load(tmp_path, device="cpu").config == model.config


def test_loading_a_missing_file_names_it(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothing.pt"):
        ShapeModel.load(tmp_path / "nothing.pt")


def test_loading_a_corrupt_file_is_a_clear_error(tmp_path):
    path = tmp_path / "corrupt.pt"
    path.write_bytes(b"this is not a checkpoint")
    with pytest.raises(ValueError, match="not a readable torch checkpoint"):
        ShapeModel.load(path)


def test_loading_a_truncated_checkpoint_is_a_clear_error(model, tmp_path):
    good = model.save(tmp_path / "m.pt").read_bytes()
    path = tmp_path / "truncated.pt"
    path.write_bytes(good[: len(good) // 2])
    with pytest.raises(ValueError, match="not a readable torch checkpoint"):
        ShapeModel.load(path)


def test_loading_another_torch_file_is_a_clear_error(tmp_path):
    path = tmp_path / "weights.pt"
    torch.save({"weight": torch.zeros(3)}, path)
    with pytest.raises(ValueError, match=f"not a {FORMAT} checkpoint"):
        ShapeModel.load(path)


def test_loading_another_format_version_is_a_clear_error(model, tmp_path):
    state = model.state()
    state["format_version"] = FORMAT_VERSION + 1
    torch.save(state, tmp_path / "future.pt")
    with pytest.raises(ValueError, match="format version"):
        ShapeModel.load(tmp_path / "future.pt")


def test_loading_mismatched_weights_is_a_clear_error(model, tmp_path):
    state = model.state()
    state["model_config"]["width"] = 64  # the weights are 32 wide
    torch.save(state, tmp_path / "bad.pt")
    with pytest.raises(ValueError, match="do not fit a ShapeModel"):
        ShapeModel.load(tmp_path / "bad.pt")


def test_flat_shapes_as_observations_hold_them_are_accepted(model):
    shapes = np.stack([np.stack([np.linspace(-0.5, 0.5, 20), np.full(20, y)], axis=1)
                       for y in (-0.2, 0.3)]).astype(np.float32)
    np.testing.assert_array_equal(model.encode(shapes.reshape(2, -1)), model.encode(shapes))
    np.testing.assert_array_equal(model.encode(shapes[0].reshape(-1)), model.encode(shapes[0]))
    z, err, ok = model.invert(shapes.reshape(2, -1))
    assert z.shape == (2, model.latent_dim) and err.shape == (2,)


@pytest.mark.parametrize(
    ("shapes", "match"),
    [
        (np.zeros((3, 19, 2)), r"shapes must have shape \(20, 2\), \(40,\), \(B, 20, 2\)"),
        (np.zeros((3, 38)), r"got \(3, 38\)"),
        (np.zeros((3, 20, 3)), r"got \(3, 20, 3\)"),
        (np.full((20, 2), np.nan), "finite"),
    ],
)
def test_bad_shapes_are_rejected_with_the_expected_shape(model, shapes, match):
    with pytest.raises(ValueError, match=match):
        model.invert(shapes)
    with pytest.raises(ValueError, match=match):
        model.encode(shapes)


def test_bad_latents_are_rejected_with_the_expected_shape(model):
    with pytest.raises(ValueError, match=r"z must have shape \(9,\) or \(B, 9\), got \(2, 5\)"):
        model.decode(np.zeros((2, 5)))


def test_device_must_be_a_device():
    with pytest.raises(ValueError, match="device"):
        ShapeModel(ModelConfig(width=8, depth=1), normalisation_for(ModelConfig()), device="gpu9")
