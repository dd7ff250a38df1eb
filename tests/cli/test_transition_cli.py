"""Specification of ``dlo collect transitions`` and ``dlo train transition``."""

from __future__ import annotations

import numpy as np
import pytest

from dlo_cli.main import main
from dlo_env import CordParams
from dlo_env.dataset.transitions import load_transitions
from latent_model import TransitionModel


@pytest.mark.slow
def test_collect_then_train_a_transition_model_from_two_files(tmp_path, capsys):
    first, second = tmp_path / "a.npz", tmp_path / "b.npz"
    for seed, out, wide in ((0, first, "0"), (1, second, "0.5")):
        assert main(["collect", "transitions", "--num-transitions", "25",
                     "--seed", str(seed), "--wide-fraction", wide, "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert f"wrote {first}" in text and "transitions: 25" in text and "grasps: head" in text
    assert len(load_transitions(first)) == 25
    assert load_transitions(second).metadata["collect"]["wide_fraction"] == 0.5
    out = tmp_path / "model"
    assert main(["train", "transition", "--data", str(first), str(second),
                 "--heldout", str(second), "--out", str(out), "--steps", "20",
                 "--width", "16", "--members", "2", "--batch-size", "32", "--eval-every", "10",
                 "--miss-weight", "2", "--miss-margin", "0.01",
                 "--no-progress"]) == 0
    text = capsys.readouterr().out
    assert "50 transitions" in text
    assert "spread-error rank correlation" in text
    model = TransitionModel.load(out)
    assert model.config.members == 2 and model.info["steps"] == 20
    assert (model.info["train_config"]["miss_weight"], model.info["train_config"]["miss_margin"]) \
        == (2, 0.01)
    again = ["train", "transition", "--data", str(first), str(second), "--heldout",
             str(second), "--out", str(out), "--steps", "20", "--width", "16", "--members", "2",
             "--batch-size", "32", "--eval-every", "10", "--no-progress"]
    assert main(again + ["--contact-reach", "0.03"]) == 2  # resuming with other settings
    assert "miss_weight=2.0 (now 0.0), miss_margin=0.01 (now 0.005), contact_reach=0.0 " \
        "(now 0.03)" in capsys.readouterr().err  # names them
    assert model.info["files"] == [str(first), str(second)]
    for name in ("transition-metrics.csv", "transition-metrics.png", "transition-training.csv"):
        assert (out / name).is_file()
    mean = tmp_path / "mean"
    distil = ["train", "transition", "--data", str(first), "--heldout", str(second),
              "--out", str(mean), "--steps", "10", "--batch-size", "32", "--eval-every", "10",
              "--teacher", str(out / "transition.pt"), "--no-progress"]
    for flag, named in ((["--width", "32"], "--width shape"), (["--peg-reach", "0.1"],
                                                               "--peg-reach shape"),
                        (["--contact-reach", "0.03"], "--contact-reach shape")):
        assert main(distil + flag) == 2
        err = capsys.readouterr().err
        assert "not --teacher's mean network" in err and named in err
    assert main(distil) == 0
    assert f"distilling {out / 'transition.pt'}" in capsys.readouterr().out
    student = TransitionModel.load(mean)
    assert student.config.mean_network and student.config.width == 16
    assert not student.config.mean_by_grasp
    split_out = [str(tmp_path / "split") if a == str(mean) else a for a in distil]
    assert main(split_out + ["--mean-by-grasp"]) == 0
    split = TransitionModel.load(tmp_path / "split")
    assert split.config.mean_by_grasp and split.config.width == 16
    contact = [str(tmp_path / "contact") if a == str(out) else a for a in again]
    assert main(contact + ["--contact-reach", "0.02"]) == 0
    assert TransitionModel.load(tmp_path / "contact").config.contact_reach == 0.02
    no_teacher = [str(tmp_path / "x") if a == str(out) else a for a in again]
    assert main(no_teacher + ["--mean-by-grasp"]) == 2
    err = capsys.readouterr().err
    assert "--mean-by-grasp" in err and "needs --teacher" in err


def test_each_kind_needs_its_own_count_and_takes_only_its_own_flags(tmp_path, capsys):
    assert main(["collect", "transitions", "--out", str(tmp_path / "x.npz")]) == 2
    assert "the following arguments are required: --num-transitions" in capsys.readouterr().err
    assert main(["collect", "shapes", "--out", str(tmp_path / "y.npz")]) == 2
    assert "the following arguments are required: --num-shapes" in capsys.readouterr().err
    assert main(["collect", "transitions", "--num-shapes", "5", "--num-transitions", "5",
                 "--out", str(tmp_path / "x.npz")]) == 2
    assert "unrecognized arguments: --num-shapes 5" in capsys.readouterr().err
    assert main(["collect", "shapes", "--num-shapes", "5", "--wide-fraction", "0.5",
                 "--out", str(tmp_path / "z.npz")]) == 2
    assert "unrecognized arguments: --wide-fraction 0.5" in capsys.readouterr().err
    assert main(["collect", "shapes", "--num-shapes", "5", "--rim-fraction", "0.5",
                 "--out", str(tmp_path / "z.npz")]) == 2
    assert "unrecognized arguments: --rim-fraction 0.5" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


def test_grasp_weights_rim_and_push_fraction_choose_the_grasps_and_the_aims(tmp_path, capsys):
    out = tmp_path / "both.npz"
    assert main(["collect", "transitions", "--num-transitions", "12",
                 "--grasp-weights", "0", "0", "2", "--out", str(out)]) == 0
    data = load_transitions(out)
    assert (data.grasp == 2).all()
    assert data.metadata["collect"]["grasp_weights"] == [0, 0, 2]
    rim = tmp_path / "rim.npz"
    assert main(["collect", "transitions", "--num-transitions", "12",
                 "--rim-fraction", "0.5", "--push-fraction", "0.5", "--out", str(rim)]) == 0
    collect = load_transitions(rim).metadata["collect"]
    assert (collect["rim_fraction"], collect["push_fraction"]) == (0.5, 0.5)
    bad = ["collect", "transitions", "--num-transitions", "12", "--out",
           str(tmp_path / "x.npz"), "--grasp-weights"]
    assert main([*bad, "0", "0", "0"]) == 2
    assert "argument --grasp-weights: grasp_weights must be 3 non-negative weights (head, tail, " \
        "both) with a positive sum, got (0.0, 0.0, 0.0)" in capsys.readouterr().err
    assert main([*bad, "1", "-1", "1"]) == 2
    assert "argument --grasp-weights: expected a number >= 0" in capsys.readouterr().err
    assert main([*bad[:-1], "--rim-fraction", "0.8"]) == 2
    assert "argument --push-fraction, --rim-fraction: push_fraction and rim_fraction must be " \
        ">= 0 with a sum <= 1, got 0.25 and 0.8" in capsys.readouterr().err
    assert main([*bad[:-1], "--push-fraction", "0.95"]) == 2
    assert "got 0.95 and 0.1" in capsys.readouterr().err
    assert main([*bad[:-1], "--wide-fraction", "0.6", "--wavy-fraction", "0.5"]) == 2
    assert "argument --wide-fraction, --wavy-fraction: wide_fraction and wavy_fraction must " \
        "have a sum <= 1, got 0.6 and 0.5" in capsys.readouterr().err
    assert not (tmp_path / "x.npz").exists()


def test_wavy_fraction_is_recorded_and_applies_to_transitions_only(tmp_path, capsys):
    out = tmp_path / "wavy.npz"
    assert main(["collect", "transitions", "--num-transitions", "6",
                 "--wavy-fraction", "0.5", "--out", str(out)]) == 0
    assert load_transitions(out).metadata["collect"]["wavy_fraction"] == 0.5
    assert main(["collect", "shapes", "--num-shapes", "5", "--wavy-fraction", "0.5",
                 "--out", str(tmp_path / "z.npz")]) == 2
    assert "unrecognized arguments: --wavy-fraction 0.5" in capsys.readouterr().err


def test_a_chain_ensemble_trains_saves_loads_and_distils_into_an_mlp_student(tmp_path, capsys):
    data = tmp_path / "a.npz"
    assert main(["collect", "transitions", "--num-transitions", "30", "--seed", "3",
                 "--grasp-weights", "1", "1", "1", "--out", str(data)]) == 0
    out, mean = tmp_path / "chain", tmp_path / "student"
    common = ["--data", str(data), "--heldout", str(data), "--steps", "6", "--batch-size", "16",
              "--eval-every", "6", "--no-progress"]
    assert main(["train", "transition", *common, "--out", str(out),
                 "--architecture", "chain", "--width", "8", "--depth", "3",
                 "--members", "2"]) == 0
    model = TransitionModel.load(out)
    assert model.config.architecture == "chain" and model.config.depth == 3
    assert type(model.net).__name__ == "EnsembleChainNet" and model.net.members == 2
    shapes = load_transitions(data).start[:4]
    for grasp, width in (("head", 2), ("tail", 2), ("both", 4)):
        moved = model.predict(shapes, grasp, np.full((4, width), 0.04, np.float32))
        assert moved.shape == shapes.shape and np.isfinite(moved).all()
    assert main(["train", "transition", *common, "--out", str(mean),
                 "--teacher", str(out / "transition.pt")]) == 0
    student = TransitionModel.load(mean)
    assert type(student.mean_net).__name__ == "EnsembleMLP"
    assert type(student.net).__name__ == "EnsembleChainNet"
    capsys.readouterr()
    assert main(["train", "transition", *common, "--out", str(tmp_path / "x"),
                 "--architecture", "transformer"]) == 2
    assert "--architecture: invalid choice" in capsys.readouterr().err


def test_a_cord_conditioned_model_trains_on_several_cords_and_predicts_each(tmp_path, capsys):
    data = tmp_path / "cords.npz"
    assert main(["collect", "transitions", "--num-transitions", "40", "--seed", "5",
                 "--randomize", "bending_stiffness=0.003:0.03", "length=0.8:1.2",
                 "--out", str(data)]) == 0
    common = ["train", "transition", "--data", str(data), "--heldout", str(data),
              "--steps", "6", "--batch-size", "16", "--eval-every", "6", "--no-progress",
              "--width", "16", "--members", "2"]
    assert main([*common, "--out", str(tmp_path / "one")]) == 2  # a model of one cord refuses
    assert "several cords" in capsys.readouterr().err
    test = tmp_path / "test-cords.npz"
    assert main(["collect", "transitions", "--num-transitions", "20", "--seed", "6",
                 "--test-cords", "--out", str(test)]) == 0
    out = tmp_path / "cords"
    common[common.index("--data") + 1:common.index("--data") + 2] = [str(data), str(test)]
    assert main([*common, "--out", str(out), "--cord-inputs"]) == 0
    model = TransitionModel.load(out)
    assert model.config.cord_inputs
    assert model.info["test_cords_left_out"] >= 20  # the test cords' moves, never trained on
    moves = load_transitions(data)
    shapes, d = moves.start[:3], np.full((3, 2), 0.05, np.float32)
    stiff, soft = (CordParams(bending_stiffness=b) for b in (0.03, 0.003))
    assert np.abs(model.predict(shapes, "head", d, params=stiff)
                  - model.predict(shapes, "head", d, params=soft)).max() > 0
    assert np.array_equal(model.predict(shapes, "head", d),
                          model.predict(shapes, "head", d, params=CordParams()))
    student = tmp_path / "student"
    assert main(["train", "transition", "--data", str(data), "--heldout", str(data),
                 "--steps", "4", "--batch-size", "16", "--eval-every", "4", "--no-progress",
                 "--out", str(student), "--teacher", str(out / "transition.pt")]) == 0
    assert TransitionModel.load(student).config.cord_inputs
