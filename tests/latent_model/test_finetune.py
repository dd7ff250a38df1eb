from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import torch

from dlo_cli.main import main
from latent_model import FinetuneConfig, ModelConfig, ShapeModel, TrainConfig, finetune
from latent_model.evaluation import foreign_shapes
from latent_model.finetune import deformed_variants
from latent_model.training import train


@pytest.fixture(scope="module")
def trained(tmp_path_factory, cord_shapes) -> ShapeModel:
    torch.set_num_threads(1)
    config = TrainConfig(batch_size=64, encoder_batch_size=64, d_steps=1, eval_every=1000,
                         eval_reference=40, eval_inversion=10, threads=1)
    return train(cord_shapes, cord_shapes, tmp_path_factory.mktemp("run"),
                 ModelConfig(width=32, depth=2), config, gan_steps=20, encoder_steps=20,
                 device="cpu", progress_bar=False)


def tiny(config: FinetuneConfig, train_config) -> FinetuneConfig:
    return replace(config, variants_per_shape=2, gan_steps=15, encoder_steps=15,
                   train=train_config)


def test_variants_are_simulated_cord_shapes_near_each_given_shape(trained):
    shapes, _ = foreign_shapes(3, seed=0)
    variants = deformed_variants(shapes, trained, FinetuneConfig(variants_per_shape=2), seed=0)
    assert variants.ndim == 3 and variants.shape[1:] == (20, 2) and len(variants) > 3
    gaps = np.linalg.norm(np.diff(variants, axis=1), axis=-1)
    assert np.abs(gaps / (1 / 19) - 1).max() < 0.02
    nearest = np.linalg.norm(variants[:, None] - shapes[None], axis=-1).mean(-1).min(axis=1)
    assert nearest.max() < 0.1  # every variant is a small deformation of some given shape


def test_finetune_trains_a_new_model_and_reports_before_and_after(
        trained, cord_shapes, tiny_train_config):
    shapes, _ = foreign_shapes(4, seed=1)
    before = [p.detach().clone() for p in trained.generator.parameters()]
    new, report = finetune(trained, shapes, cord_shapes, None,
                           tiny(FinetuneConfig(), tiny_train_config), progress_bar=False)
    assert report.n_shapes == 4 and report.n_unrepresented == 4 and report.n_variants > 4
    assert 0.0 <= report.success_after <= 1.0 and report.heldout_before is None
    assert new is not trained
    assert all(torch.equal(a, b) for a, b in zip(before, trained.generator.parameters()))
    assert any(not torch.equal(a, b) for a, b in zip(before, new.generator.parameters()))
    assert "inversion success on the shapes" in report.format()


def test_finetune_refuses_a_model_without_discriminator(trained, cord_shapes):
    bare = ShapeModel(trained.config, trained.normalisation, trained.generator, trained.encoder,
                      None, "cpu")
    with pytest.raises(ValueError, match="no discriminator"):
        finetune(bare, cord_shapes[:2], cord_shapes)


def test_finetune_rejects_shapes_of_the_wrong_size(trained, cord_shapes):
    with pytest.raises(ValueError, match=r"shapes must have shape \(20, 2\)"):
        finetune(trained, np.zeros((3, 7, 2), np.float32), cord_shapes)


def test_dlo_finetune_writes_the_new_model_and_its_report(tmp_path, trained, cord_shapes,
                                                          capsys):
    data = tmp_path / "train.npz"
    np.savez(data, shapes=cord_shapes)
    targets = tmp_path / "targets.npz"
    np.savez(targets, shapes=foreign_shapes(2, seed=2)[0])
    (tmp_path / "model").mkdir()
    trained.save(tmp_path / "model" / "model.pt")
    out = tmp_path / "better"
    code = main(["finetune", "--model", str(tmp_path / "model"), "--shapes", str(targets),
                 "--data", str(data), "--out", str(out), "--gan-steps", "5",
                 "--encoder-steps", "5", "--no-progress", "--device", "cpu",
                 "--report-size", "10"])
    assert code == 0
    assert "inversion success on the shapes" in capsys.readouterr().out
    assert ShapeModel.load(out / "model.pt", device="cpu").n_points == 20
    assert (out / "finetune_report.json").exists()
    before = (out / "model.pt").read_bytes()
    assert main(["finetune", "--model", str(tmp_path / "model"), "--shapes", str(targets),
                 "--data", str(data), "--out", str(out)]) == 2  # never replaced
    assert "holds a model (model.pt)" in capsys.readouterr().err
    assert (out / "model.pt").read_bytes() == before


def test_dlo_finetune_names_the_model_flag_and_the_recorded_files_it_lacks(tmp_path, trained,
                                                                           capsys):
    targets = tmp_path / "targets.npz"
    np.savez(targets, shapes=foreign_shapes(2, seed=2)[0])
    assert main(["finetune", "--model", str(targets), "--shapes", str(targets)]) == 2
    assert capsys.readouterr().err.startswith("dlo finetune: error: --model: ")
    info = dict(trained.info)
    trained.info = {**info, "data": ["data/gone.npz", "data/gone-too.npz"]}
    try:
        trained.save(tmp_path / "model.pt")
    finally:
        trained.info = info
    assert main(["finetune", "--model", str(tmp_path / "model.pt"), "--shapes",
                 str(targets)]) == 2
    assert ("training data the model records (data/gone.npz, data/gone-too.npz) is not "
            "here") in capsys.readouterr().err


@pytest.mark.parametrize("recorded", ["one path", "a list"])
def test_dlo_finetune_reads_the_training_files_the_model_records(tmp_path, trained, cord_shapes,
                                                                 capsys, recorded):
    data = tmp_path / "train.npz"
    np.savez(data, shapes=cord_shapes)
    targets = tmp_path / "targets.npz"
    np.savez(targets, shapes=foreign_shapes(2, seed=2)[0])
    (tmp_path / "model").mkdir()
    info = dict(trained.info)
    trained.info = {**info, "data": str(data) if recorded == "one path" else [str(data)],
                    "heldout": "None" if recorded == "one path" else None}
    try:
        trained.save(tmp_path / "model" / "model.pt")
    finally:
        trained.info = info
    assert main(["finetune", "--model", str(tmp_path / "model"), "--shapes", str(targets),
                 "--out", str(tmp_path / "better"), "--gan-steps", "2", "--encoder-steps", "2",
                 "--no-progress", "--device", "cpu", "--report-size", "10"]) == 0
    assert f"training data ['{data}']" in capsys.readouterr().out
