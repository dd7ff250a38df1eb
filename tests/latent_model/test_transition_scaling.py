"""The learning-curve script (benchmarks/transition_scaling.py): subsets, fits and a tiny run."""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest
from scripts import load_script

from dlo_env.dataset.transitions import (
    TransitionCollectConfig,
    collect_transition_chunk,
    save_transitions,
    split_transitions,
)
from latent_model.transition_training import TransitionTrainConfig


def _script():
    return load_script("benchmarks/transition_scaling.py")


@pytest.fixture(scope="module")
def data():
    return collect_transition_chunk(TransitionCollectConfig(seed=3), 0, 40)


def test_subsets_are_whole_first_episodes_of_at_least_the_size(data):
    scaling = _script()
    for size in (1, 7, 23, len(data)):
        part = scaling.first_episodes(data, size)
        assert len(part) >= size
        kept = np.unique(part.episode)
        # whole episodes, the first ones by id, and no episode more than needed
        assert np.array_equal(kept, np.unique(data.episode)[:len(kept)])
        assert len(part) == np.isin(data.episode, kept).sum()
        assert len(part) - np.sum(part.episode == kept[-1]) < size
    with pytest.raises(ValueError, match="--sizes"):
        scaling.first_episodes(data, len(data) + 1)


def test_the_fit_sample_holds_only_moves_the_network_trained_on(data):
    scaling = _script()
    tc = TransitionTrainConfig(steps=1, validation_fraction=0.25, seed=2)
    _, held_back = split_transitions(data, tc.validation_fraction, seed=tc.seed)
    sample = scaling.trained_sample(data, tc, 1000)
    assert len(sample) == len(data) - len(held_back)  # all of them, when fewer than asked
    assert not np.isin(sample.episode, held_back.episode).any()
    assert len(scaling.trained_sample(data, tc, 5)) == 5


def test_the_power_law_is_recovered_and_solved_for_the_floor():
    scaling = _script()
    sizes = np.array([1e4, 2e4, 4e4, 8e4])
    misses = 0.2 * (sizes / 1e4) ** -0.5
    a, b = scaling.power_law(sizes, misses)
    assert b == pytest.approx(-0.5) and np.exp(a) * 1e4 ** b == pytest.approx(0.2)
    # 0.2 * (n / 1e4) ** -0.5 = 0.01  ->  n = 1e4 * 20 ** 2
    assert scaling.needed((a, b), 0.99) == pytest.approx(4e6, rel=1e-6)
    assert scaling.size_for((a, b), 0.1) == pytest.approx(4e4, rel=1e-6)
    # misses that do not fall, too few points, or a floor beyond any float never get there
    assert scaling.needed(scaling.power_law(sizes, misses[::-1]), 0.99) == float("inf")
    assert scaling.power_law(sizes, np.array([0.1, 0, np.nan, 0])) is None
    assert scaling.needed(None, 0.99) == float("inf")
    assert scaling.size_for((0.0, -1e-6), 0.01) == float("inf")
    assert scaling.transitions(float("inf")) == "never (no fall)"


def _argv(path, out, *extra):
    return ["x", "--data", str(path), "--validation", str(path.with_name("v.npz")),
            "--fit-sample", "20", "--runs", str(out / "runs"), "--out", str(out), *extra]


@pytest.fixture
def files(data, tmp_path):
    path = tmp_path / "t.npz"
    save_transitions(path, data)
    save_transitions(tmp_path / "v.npz", collect_transition_chunk(
        TransitionCollectConfig(seed=4), 0, 30))
    return path


def test_a_tiny_curve_runs_resumes_and_fits_its_own_settings_only(files, tmp_path,
                                                                  monkeypatch, capsys):
    scaling = _script()
    out = tmp_path / "out"
    for extra in (["--sizes", "10", "20"], ["--sizes", "40", "--reference-size", "800"],
                  ["--sizes", "20", "--steps", "4"]):  # other steps: another curve
        monkeypatch.setattr(sys, "argv", _argv(files, out, "--steps", "3", *extra))
        scaling.main()
    rows = json.loads((out / "scaling-s3-w256-seed0.json").read_text())
    assert [r["size"] for r in rows] == [10, 20, 40]
    assert [r["size"] for r in json.loads((out / "scaling-s4-w256-seed0.json").read_text())] \
        == [20]
    for r in rows:
        for g in ("head", "tail", "both"):
            assert r["unseen"][g]["moves"] > 0 and 0 <= r["unseen"][g]["within"] <= 1
        assert sum(r["train"][g]["moves"] for g in ("head", "tail", "both")) <= 20
    assert (out / "scaling-s3-w256-seed0.png").stat().st_size > 0
    fit = json.loads((out / "scaling-fit-s3-w256-seed0.json").read_text())
    assert set(fit) == {"settings", "head", "tail", "both", "reference"}
    printed = capsys.readouterr().out
    assert "fitted over 3 sizes" in printed and "the shipped model on the same moves" in printed
    # a second run of a finished size trains nothing more: its curve file is untouched
    curve = out / "runs" / "n20-s3-w256-seed0" / "transition-training.csv"
    before = curve.stat().st_mtime_ns, curve.read_text()
    monkeypatch.setattr(sys, "argv", _argv(files, out, "--steps", "3", "--sizes", "20"))
    scaling.main()
    assert (curve.stat().st_mtime_ns, curve.read_text()) == before


def test_a_chain_network_curve_is_its_own(files, tmp_path, monkeypatch, capsys):
    scaling = _script()
    out = tmp_path / "out"
    monkeypatch.setattr(sys, "argv", _argv(files, out, "--steps", "2", "--sizes", "10", "20",
                                           "--architecture", "chain", "--width", "8",
                                           "--depth", "2"))
    scaling.main()
    rows = json.loads((out / "scaling-s2-w8-seed0-chain-d2.json").read_text())
    assert [r["size"] for r in rows] == [10, 20]
    assert all(r["architecture"] == "chain" and r["depth"] == 2 for r in rows)
    assert (out / "runs" / "n10-s2-w8-seed0-chain-d2" / "transition.pt").is_file()
    assert "width 8-chain-d2" in capsys.readouterr().out


@pytest.mark.parametrize("extra, message", [
    (["--sizes", "10", "1000"], "--sizes: 1000 is more than --data's"),
    (["--sizes", "0"], "--sizes must all be >= 1"),
    (["--steps", "0"], "--steps must be >= 1"),
    (["--fit-sample", "0"], "--fit-sample must be >= 1"),
    (["--reference-size", "inf"], "--reference-size must be a positive number"),
])
def test_bad_arguments_are_refused_before_any_training(files, tmp_path, monkeypatch, capsys,
                                                       extra, message):
    scaling = _script()
    monkeypatch.setattr(sys, "argv", _argv(files, tmp_path, "--steps", "3", *extra))
    with pytest.raises(SystemExit):
        scaling.main()
    assert message in capsys.readouterr().err
    assert not (tmp_path / "runs").exists()


def test_the_validation_file_must_not_be_the_training_file(files, tmp_path, monkeypatch, capsys):
    scaling = _script()
    monkeypatch.setattr(sys, "argv", ["x", "--data", str(files), "--validation", str(files),
                                      "--steps", "3", "--sizes", "10"])
    with pytest.raises(SystemExit):
        scaling.main()
    assert "--validation must be another file than --data" in capsys.readouterr().err
