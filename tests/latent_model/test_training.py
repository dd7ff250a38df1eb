from __future__ import annotations

import csv
import math
from dataclasses import replace

import numpy as np
import pytest
import torch

from latent_model.checkpoint import load_checkpoint
from latent_model.shape_model import ShapeModel
from latent_model.training import Trainer, train


def test_encoder_steps_lower_the_reconstruction_loss(cord_shapes, tiny_config, tiny_train_config):
    trainer = Trainer(cord_shapes, cord_shapes, tiny_config, tiny_train_config, "cpu", seed=0)
    # Shapes the (untrained) generator can produce, so a perfect Encoder exists.
    with torch.no_grad():
        trainer.data = trainer.generator(trainer._latent(300))
    first = np.mean([trainer.encoder_step() for _ in range(3)])
    for _ in range(60):
        trainer.encoder_step()
    last = np.mean([trainer.encoder_step() for _ in range(3)])
    assert last < 0.5 * first


def test_joint_reconstruction_trains_encoder_and_generator_together(
        cord_shapes, tiny_config, tiny_train_config):
    config = replace(tiny_train_config, reconstruction_weight=10.0, prior_weight=1.0,
                     spacing_weight=0.5, lr_generator=1e-3, lr_encoder=1e-3)
    trainer = Trainer(cord_shapes, cord_shapes, tiny_config, config, "cpu", seed=0)
    encoder_before = [p.detach().clone() for p in trainer.encoder.parameters()]
    trainer.gan_step()
    first = trainer.last["loss_e"]
    for _ in range(60):
        trainer.gan_step()
    assert trainer.last["loss_e"] < 0.5 * first
    assert all(not torch.equal(a, b) for a, b in zip(encoder_before, trainer.encoder.parameters()))


def test_generator_steps_with_only_the_spacing_loss_lower_it(cord_shapes, tiny_config,
                                                            tiny_train_config):
    config = replace(tiny_train_config, spacing_weight=1.0, lr_generator=1e-3)
    trainer = Trainer(cord_shapes, cord_shapes, tiny_config, config, "cpu", seed=0)
    first = trainer.gan_step()[1]
    for _ in range(40):
        loss = trainer.gan_step()[1]
    assert loss < 0.5 * first


def test_training_data_is_canonical_and_inside_the_tanh_range(cord_shapes, tiny_config,
                                                             tiny_train_config):
    trainer = Trainer(cord_shapes, cord_shapes, tiny_config, tiny_train_config, "cpu", seed=0)
    assert trainer.data.abs().max() < 1.0
    assert trainer.data.mean(dim=1).abs().max() < 1e-5  # centred
    # d_r is the mean point spacing in network units: 1/19 m over 0.525 m per unit
    assert trainer.rest == pytest.approx(1 / 19 / 0.525, rel=0.02)


def test_the_same_seed_gives_the_same_training(cord_shapes, tiny_config, tiny_train_config):
    runs = []
    for _ in range(2):
        trainer = Trainer(cord_shapes, cord_shapes, tiny_config, tiny_train_config, "cpu", seed=3)
        runs.append([trainer.gan_step() for _ in range(3)])
    assert runs[0] == runs[1]


def test_cosine_schedule_goes_from_the_base_rate_to_zero(cord_shapes, tiny_config,
                                                         tiny_train_config):
    tc = replace(tiny_train_config, lr_generator=1e-3, lr_discriminator=2e-3, lr_encoder=4e-3)
    trainer = Trainer(cord_shapes, cord_shapes, tiny_config, tc, "cpu", seed=0)
    rates = []
    for fraction in (0.0, 0.5, 1.0):
        trainer.set_lr_fraction(fraction)
        rates.append([opt.param_groups[0]["lr"]
                      for opt in (trainer.opt_g, trainer.opt_d, trainer.opt_e)])
    assert rates[0] == pytest.approx([1e-3, 2e-3, 4e-3])
    assert rates[1] == pytest.approx([0.5e-3, 1e-3, 2e-3])
    assert rates[2] == pytest.approx([0.0, 0.0, 0.0], abs=1e-12)
    constant = Trainer(cord_shapes, cord_shapes, tiny_config,
                       replace(tc, lr_schedule="constant"), "cpu", seed=0)
    constant.set_lr_fraction(0.9)
    assert constant.opt_d.param_groups[0]["lr"] == pytest.approx(2e-3)
    with pytest.raises(ValueError, match="lr_schedule"):
        replace(tc, lr_schedule="linear")


@pytest.mark.slow
def test_train_writes_logs_checkpoints_and_resumes(cord_shapes, tiny_config, tiny_train_config,
                                                    tmp_path):
    config = replace(tiny_train_config, eval_every=3)
    kw = dict(model_config=tiny_config, train_config=config, device="cpu", seed=0,
              progress_bar=False, encoder_steps=2)
    train(cord_shapes, cord_shapes, tmp_path, gan_steps=3, **kw)
    for name in ("checkpoint.pt", "model.pt", "metrics.csv", "metrics.png"):
        assert (tmp_path / name).is_file(), name
    first = load_checkpoint(tmp_path / "checkpoint.pt")
    assert first["progress"]["gan_step"] == 3 and first["progress"]["encoder_step"] == 2

    model = train(cord_shapes, cord_shapes, tmp_path, gan_steps=6, **kw)  # resumes at step 3
    state = load_checkpoint(tmp_path / "checkpoint.pt")
    assert state["progress"]["gan_step"] == 6
    with open(tmp_path / "metrics.csv") as f:
        rows = list(csv.DictReader(f))
    assert [(r["stage"], r["step"]) for r in rows if r["stage"] != "gan-best"] == [
        ("gan", "3"), ("encoder", "2"), ("gan", "6"), ("encoder", "2")
    ]
    # The GAN stage ends with the networks of its best evaluation (COV - 1-NNA); when that is
    # not the last one, a "gan-best" row repeats it.
    scores = {r["step"]: float(r["cov"]) - float(r["nna"]) for r in rows if r["stage"] == "gan"}
    best_step = state["progress"]["best_step"]
    assert str(best_step) == max(scores, key=scores.get)
    best_rows = [(r["stage"], r["step"]) for r in rows if r["stage"] == "gan-best"]
    assert best_rows == ([] if best_step == 6 else [("gan-best", str(best_step))])
    for name, value in state["best"]["generator"].items():
        assert torch.equal(value, state["generator"][name])
    minutes = [float(r["train_minutes"]) for r in rows if r["stage"] != "gan-best"]
    assert minutes == sorted(minutes)
    loaded = ShapeModel.load(tmp_path, device="cpu")
    z = model.sample_latent(3, seed=0)
    assert np.array_equal(loaded.decode(z), model.decode(z))


def test_train_follows_the_cosine_schedule(cord_shapes, tiny_config, tiny_train_config,
                                           tmp_path):
    train(cord_shapes, cord_shapes, tmp_path, tiny_config, tiny_train_config, stage="gan",
          gan_steps=4, device="cpu", seed=0, progress_bar=False)
    state = load_checkpoint(tmp_path / "checkpoint.pt")
    last = state["opt_g"]["param_groups"][0]["lr"]  # the rate of the 4th (last) step
    expected = tiny_train_config.lr_generator * 0.5 * (1 + math.cos(0.75 * math.pi))
    assert last == pytest.approx(expected)


def test_checkpoints_from_before_the_schedule_resume_as_constant(
        cord_shapes, tiny_config, tiny_train_config, tmp_path):
    constant = replace(tiny_train_config, lr_schedule="constant")
    kw = dict(device="cpu", seed=0, progress_bar=False, encoder_steps=1)
    train(cord_shapes, cord_shapes, tmp_path, tiny_config, constant, gan_steps=1, **kw)
    state = load_checkpoint(tmp_path / "checkpoint.pt")
    del state["train_config"]["lr_schedule"]  # as written before the field existed
    torch.save(state, tmp_path / "checkpoint.pt")
    train(cord_shapes, cord_shapes, tmp_path, tiny_config, constant, gan_steps=2, **kw)
    assert load_checkpoint(tmp_path / "checkpoint.pt")["progress"]["gan_step"] == 2
    with pytest.raises(ValueError, match="different train_config"):
        train(cord_shapes, cord_shapes, tmp_path, tiny_config, tiny_train_config, gan_steps=3,
              **kw)


def test_resuming_with_other_settings_is_refused(cord_shapes, tiny_config, tiny_train_config,
                                                 tmp_path):
    kw = dict(device="cpu", seed=0, progress_bar=False, gan_steps=1, encoder_steps=1)
    train(cord_shapes, cord_shapes, tmp_path, tiny_config, tiny_train_config, **kw)
    other = replace(tiny_train_config, batch_size=32)
    with pytest.raises(ValueError, match="different train_config"):
        train(cord_shapes, cord_shapes, tmp_path, tiny_config, other, **kw)


def test_encoder_stage_needs_a_trained_gan(cord_shapes, tmp_path):
    with pytest.raises(ValueError, match="needs a trained GAN"):
        train(cord_shapes, cord_shapes, tmp_path, stage="encoder", device="cpu",
              progress_bar=False)


def test_unknown_stage_is_rejected(cord_shapes, tmp_path):
    with pytest.raises(ValueError, match="stage must be one of"):
        train(cord_shapes, cord_shapes, tmp_path, stage="everything")


def test_evaluation_subsets_are_disjoint_seeded_and_spread_over_the_file():
    from latent_model.dataset import evaluation_subsets

    shapes = np.arange(1000, dtype=np.float32)[:, None, None] * np.ones((1, 20, 2), np.float32)
    ref, inv = evaluation_subsets(shapes, (100, 50), seed=0)
    again, _ = evaluation_subsets(shapes, (100, 50), seed=0)
    ids_ref, ids_inv = set(ref[:, 0, 0].tolist()), set(inv[:, 0, 0].tolist())
    assert len(ids_ref) == 100 and len(ids_inv) == 50 and not ids_ref & ids_inv
    assert np.array_equal(ref, again)
    assert max(ids_ref) > 500  # not the first shapes of the file
    with pytest.raises(ValueError, match="at least 1500 shapes"):
        evaluation_subsets(shapes, (1000, 500))


def test_gan_stage_ends_with_the_best_evaluated_networks(tmp_path, cord_shapes, tiny_config,
                                                         tiny_train_config):
    config = replace(tiny_train_config, eval_every=5)
    train(cord_shapes, cord_shapes, tmp_path, tiny_config, config, stage="gan", gan_steps=20,
          device="cpu", progress_bar=False)
    rows = list(csv.DictReader(open(tmp_path / "metrics.csv")))
    gan = [r for r in rows if r["stage"] == "gan"]
    best = max(gan, key=lambda r: float(r["cov"]) - float(r["nna"]))
    chosen = load_checkpoint(tmp_path / "checkpoint.pt")["progress"]["best_step"]
    assert chosen == int(best["step"])
    if chosen != 20:
        assert rows[-1]["stage"] == "gan-best" and int(rows[-1]["step"]) == chosen
