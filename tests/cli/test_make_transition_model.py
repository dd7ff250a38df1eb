"""Specification of ``examples/make_transition_model.py``: the shipped model's recipe in one
command (here scaled down to a few transitions and steps)."""

from __future__ import annotations

import importlib.util
import shutil
from dataclasses import asdict
from pathlib import Path

import pytest

from dlo_env.dataset.transitions import load_transitions
from latent_model import TransitionModel
from latent_model.transition_model import TransitionModelConfig
from latent_model.transition_training import TransitionTrainConfig, fingerprint

SCRIPT = Path(__file__).resolve().parents[2] / "examples" / "make_transition_model.py"


def _recipe():
    spec = importlib.util.spec_from_file_location("make_transition_model", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
def test_the_recipe_collects_trains_distils_and_resumes(tmp_path, capsys):
    recipe = _recipe()
    scale = 0.0003
    argv = ["--scale", str(scale), "--out", str(tmp_path / "run"), "--data-dir",
            str(tmp_path / "data"), "--workers", "1", "--threads", "1"]
    recipe.main(argv)
    for name, count, seed, wide in recipe.DATA:
        data = load_transitions(tmp_path / "data" / name)
        assert len(data) == max(1, round(count * scale))
        assert data.metadata["collect"]["seed"] == seed
        assert data.metadata["collect"]["wide_fraction"] == wide
    ensemble = TransitionModel.load(tmp_path / "run" / "ensemble" / "transition.pt")
    assert ensemble.mean_net is None
    assert ensemble.info["steps"] == round(recipe.ENSEMBLE_STEPS * scale)
    model = TransitionModel.load(tmp_path / "run" / "mean" / "transition.pt")
    assert model.mean_net is not None and model.config.mean_network
    assert model.info["steps"] == round(recipe.MEAN_STEPS * scale)
    assert model.info["train_config"]["lr"] == recipe.MEAN_LR
    assert model.info["train_config"]["teacher_moves"] == recipe.MEAN_TEACHER_MOVES
    trained = [name for name, *_ in recipe.DATA[:-1]]
    assert [Path(f).name for f in model.info["files"]] == trained
    assert [(src["collect"]["seed"], src["collect"]["wide_fraction"], src["transitions"])
            for src in model.info["sources"]] == [
        (seed, wide, max(1, round(count * scale))) for _, count, seed, wide in recipe.DATA[:-1]]
    assert model.info["teacher_ensemble"] == fingerprint(ensemble.net)  # distils this ensemble
    capsys.readouterr()

    recipe.main(argv)  # again: every file reused, both trainings already done
    text = capsys.readouterr().out
    assert text.count("as the recipe says") == len(recipe.DATA)
    assert "dlo collect" not in text and text.count("resuming in") == 2

    with pytest.raises(SystemExit, match="transitions-train.npz is not the recipe's file.*"
                                         "transitions differ"):
        recipe.main([*argv[:1], str(2 * scale), *argv[2:]])

    # A file of another seed and wide fraction in a recipe file's place, and a corrupt one:
    # both named in one line, before anything is collected (the missing held-out file stays so).
    data = tmp_path / "data"
    shutil.copy(data / "transitions-train-3.npz", data / "transitions-train-5.npz")
    (data / "transitions-train-6.npz").write_bytes(b"not an npz")
    (data / "transitions-heldout.npz").unlink()
    with pytest.raises(SystemExit) as error:
        recipe.main(argv)
    text = str(error.value)
    assert "\n" not in text
    assert "transitions-train-5.npz is not the recipe's file" in text
    assert "seed, wide_fraction differ" in text
    assert "transitions-train-6.npz cannot be read" in text
    assert not (data / "transitions-heldout.npz").exists()


def test_the_recipe_runs_these_dlo_commands_and_a_trial_keeps_to_its_own_folder(
        tmp_path, monkeypatch):
    recipe = _recipe()
    calls = []
    monkeypatch.setattr(recipe, "dlo", lambda *argv: calls.append([str(a) for a in argv]))
    monkeypatch.setattr(recipe, "ROOT", tmp_path)
    recipe.main(["--scale", "0.001"])
    trial = tmp_path / "runs" / "transition-recipe-scale-0.001"
    collects = [c for c in calls if c[0] == "collect"]
    assert [c[c.index("--out") + 1] for c in collects] == [
        str(trial / "data" / name) for name, *_ in recipe.DATA]
    assert all("--resume" in c for c in collects)
    ensemble, mean = [c for c in calls if c[0] == "train"]
    for command in (ensemble, mean):
        assert command[command.index("--heldout") + 1] == str(
            trial / "data" / "transitions-heldout.npz")
    assert ensemble[ensemble.index("--out") + 1] == str(trial / "ensemble")
    assert mean[mean.index("--teacher") + 1] == str(trial / "ensemble" / "transition.pt")
    assert mean[mean.index("--teacher-moves") + 1] == str(recipe.MEAN_TEACHER_MOVES)
    assert not (tmp_path / "data").exists()  # the full recipe's data folder is not touched


@pytest.mark.parametrize("flag, value", [("--workers", "0"), ("--threads", "-1"),
                                         ("--scale", "1.5")])
def test_bad_flags_are_one_line_errors(flag, value, capsys):
    with pytest.raises(SystemExit):
        _recipe().main([flag, value])
    assert flag in capsys.readouterr().err


def test_the_shipped_model_was_trained_with_exactly_the_recipes_settings():
    """Change the recipe and this fails until the shipped model is made by it again."""
    recipe = _recipe()
    model = TransitionModel.load_or_pretrained()
    info, trained = model.info, recipe.DATA[:-1]
    for made in (info, info["ensemble"]):
        assert [Path(f).name for f in made["files"]] == [name for name, *_ in trained]
        assert made["data_transitions"] == sum(count for _, count, *_ in trained)
    defaults = asdict(TransitionTrainConfig())
    ensemble = {**defaults, "steps": recipe.ENSEMBLE_STEPS}
    mean = {**defaults, "steps": recipe.MEAN_STEPS, "lr": recipe.MEAN_LR,
            "teacher_moves": recipe.MEAN_TEACHER_MOVES}
    for saved, want in ((info["ensemble"]["train_config"], ensemble),
                        (info["train_config"], mean)):
        assert {k: v for k, v in saved.items() if k != "teacher"} == {
            k: want[k] for k in saved if k != "teacher"}
    assert info["train_config"]["teacher"] and info["ensemble"]["train_config"]["teacher"] is None
    assert info["teacher_ensemble"] == fingerprint(model.net)
    assert asdict(model.config) == asdict(TransitionModelConfig(mean_network=True))
