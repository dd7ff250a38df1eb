"""Specification of ``examples/make_transition_model.py``: the shipped model's recipe in one
command (here scaled down to a few transitions and steps)."""

from __future__ import annotations

import shutil
from dataclasses import asdict
from pathlib import Path

import pytest
from scripts import load_script

from dlo_env.dataset.transitions import TransitionCollectConfig, load_transitions
from latent_model import TransitionModel
from latent_model.transition_model import TransitionModelConfig
from latent_model.transition_training import RETIRED_TRAIN, TransitionTrainConfig, fingerprint


def _recipe():
    return load_script("examples/make_transition_model.py")


def _stage(recipe, name):
    return next(stage for stage in recipe.TRAININGS if stage[0] == name)


def _check_training(recipe, info, name, scale=1.0):
    """``info`` is what training ``name`` of the recipe records, at ``scale``; and so is the
    provenance it holds of the trainings it started from (teacher, init), recursively."""
    _, used, settings = _stage(recipe, name)
    trained = recipe.DATA[:used]
    assert [Path(f).name for f in info["files"]] == [file for file, *_ in trained]
    assert info["data_transitions"] == sum(max(1, round(n * scale)) for _, n, _ in trained)
    collected = [TransitionCollectConfig(**settings).to_json() for *_, settings in trained]
    defaults = TransitionCollectConfig().to_json()  # of options newer than a file
    def full(recorded):  # options and cord fields newer than a file at their defaults
        return {**defaults, **recorded, "cord": {**defaults["cord"], **recorded.get("cord", {})}}

    if "sources" in info:  # models trained since each file's settings are recorded
        assert [full(src["collect"]) for src in info["sources"]] == collected
    else:  # before, only the first file's
        assert full(info["data"]) == collected[0]
    want = {**asdict(TransitionTrainConfig()), **settings,
            "steps": max(1, round(settings["steps"] * scale))}
    saved = dict(info["train_config"])
    assert saved.pop("chain_weight", 0.0) == 0.0  # the retired chain loss was off
    saved = {k: v for k, v in saved.items() if k not in RETIRED_TRAIN}
    assert {k: v for k, v in saved.items() if k not in ("teacher", "init")} == {
        k: want[k] for k in saved if k not in ("teacher", "init")}
    for key, provenance in (("teacher", lambda: info["ensemble"]),
                            ("init", lambda: info["init_model"]["info"])):
        assert bool(saved[key]) == (key in settings)
        if key in settings:
            _check_training(recipe, provenance(), settings[key], scale)


@pytest.mark.slow
def test_the_recipe_collects_trains_distils_and_resumes(tmp_path, capsys):
    recipe = _recipe()
    scale = 0.0003
    argv = ["--scale", str(scale), "--out", str(tmp_path / "run"), "--data-dir",
            str(tmp_path / "data"), "--workers", "1", "--threads", "1"]
    recipe.main(argv)
    defaults = TransitionCollectConfig().to_json()
    for name, count, settings in recipe.DATA:
        data = load_transitions(tmp_path / "data" / name)
        assert len(data) == max(1, round(count * scale))
        assert data.metadata["collect"] == {**defaults, **TransitionCollectConfig(
            **settings).to_json()}
    for name, used, settings in recipe.TRAININGS:
        model = TransitionModel.load(tmp_path / "run" / name / "transition.pt")
        _check_training(recipe, model.info, name, scale)
        assert model.config.mean_by_grasp == settings.get("mean_by_grasp", False)
        assert [src["collect"] for src in model.info["sources"]] == [
            load_transitions(tmp_path / "data" / file).metadata["collect"]
            for file, *_ in recipe.DATA[:used]]
    shipped = TransitionModel.load(tmp_path / "run" / recipe.SHIPPED / "transition.pt")
    teacher = _stage(recipe, recipe.SHIPPED)[2]["teacher"]
    ensemble = TransitionModel.load(tmp_path / "run" / teacher / "transition.pt")
    assert shipped.mean_net is not None and shipped.config.mean_network
    assert shipped.info["teacher_ensemble"] == fingerprint(ensemble.net)  # distils this one
    capsys.readouterr()

    recipe.main(argv)  # again: every file reused, both trainings already done
    text = capsys.readouterr().out
    assert text.count("as the recipe says") == len(recipe.DATA)
    assert "dlo collect" not in text
    assert text.count("resuming in") == len(recipe.TRAININGS)

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
    trains = [c for c in calls if c[0] == "train"]
    assert len(trains) == len(recipe.TRAININGS)
    for command, (folder, used, settings) in zip(trains, recipe.TRAININGS):
        def value(flag, command=command):
            return command[command.index(flag) + 1]
        assert value("--out") == str(trial / folder)
        assert value("--heldout") == str(trial / "data" / recipe.DATA[-1][0])
        data = command[command.index("--data") + 1:command.index("--heldout")]
        assert data == [str(trial / "data" / name) for name, *_ in recipe.DATA[:used]]
        for key, setting in settings.items():
            flag = "--" + key.replace("_", "-")
            if key in ("teacher", "init"):  # an earlier training's model
                assert value(flag) == str(trial / setting / "transition.pt")
            elif key == "steps":
                assert value(flag) == str(max(1, round(setting * 0.001)))
            elif isinstance(setting, bool):  # a switch: there, with no value, when True
                assert (flag in command) == setting
            else:
                assert value(flag) == str(setting)
    assert not (tmp_path / "data").exists()  # the full recipe's data folder is not touched


def test_the_full_recipe_reads_data_and_writes_runs_of_the_repository(tmp_path, monkeypatch):
    recipe = _recipe()
    calls = []
    monkeypatch.setattr(recipe, "dlo", lambda *argv: calls.append([str(a) for a in argv]))
    monkeypatch.setattr(recipe, "ROOT", tmp_path)
    monkeypatch.chdir(tmp_path)  # paths inside the working directory are given relative to it
    recipe.main([])
    outs = [c[c.index("--out") + 1] for c in calls]
    assert outs == [str(Path("data") / name) for name, *_ in recipe.DATA] + [
        str(Path("runs") / "transition-recipe" / folder) for folder, *_ in recipe.TRAININGS]
    count = calls[0][calls[0].index("--num-transitions") + 1]
    assert count == str(recipe.DATA[0][1])  # unscaled


@pytest.mark.parametrize("flag, value", [("--workers", "0"), ("--threads", "-1"),
                                         ("--scale", "1.5"), ("--scale", "nan")])
def test_bad_flags_are_one_line_errors_of_the_script(flag, value, tmp_path, monkeypatch, capsys):
    recipe = _recipe()
    monkeypatch.setattr(recipe, "dlo", lambda *argv: pytest.fail(f"ran dlo {argv}"))
    monkeypatch.setattr(recipe, "ROOT", tmp_path)
    with pytest.raises(SystemExit) as exc:
        recipe.main([flag, value])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[0].startswith("usage:") and len([line for line in err if "error:" in line]) == 1
    assert err[-1].split("error: ")[1].startswith(f"argument {flag}" if flag != "--scale"
                                                   else "--scale must be in (0, 1]")
    assert not any(tmp_path.iterdir())


def test_the_shipped_model_was_trained_with_exactly_the_recipes_settings():
    """Change the recipe and this fails until the shipped model is made by it again."""
    recipe = _recipe()
    model = TransitionModel.load_or_pretrained()
    _check_training(recipe, model.info, recipe.SHIPPED)
    assert model.info["teacher_ensemble"] == fingerprint(model.net)
    shipped = _stage(recipe, recipe.SHIPPED)[2]
    split = shipped.get("mean_by_grasp", False)
    contact = _stage(recipe, shipped["teacher"])[2].get("contact_reach", 0.0)
    assert asdict(model.config) == asdict(TransitionModelConfig(
        mean_network=True, mean_by_grasp=split, contact_reach=contact))
