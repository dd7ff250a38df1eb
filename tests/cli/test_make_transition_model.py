"""Specification of ``examples/make_transition_model.py``: the shipped model's recipe in one
command (here scaled down to a few transitions and steps)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from dlo_env.dataset.transitions import load_transitions
from latent_model import TransitionModel

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
    trained = [name for name, *_ in recipe.DATA[:-1]]
    assert [Path(f).name for f in model.info["files"]] == trained
    capsys.readouterr()

    recipe.main(argv)  # again: every file reused, both trainings already done
    text = capsys.readouterr().out
    assert text.count("as the recipe says") == len(recipe.DATA)
    assert "dlo collect" not in text and text.count("resuming in") == 2

    with pytest.raises(SystemExit, match="transitions-train.npz is not the recipe's file.*"
                                         "transitions differ"):
        recipe.main([*argv[:1], str(2 * scale), *argv[2:]])
