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
)


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


def test_the_power_law_is_recovered_and_solved_for_the_floor():
    scaling = _script()
    sizes = np.array([1e4, 2e4, 4e4, 8e4])
    misses = 0.2 * (sizes / 1e4) ** -0.5
    a, b = scaling.power_law(sizes, misses)
    assert b == pytest.approx(-0.5) and np.exp(a) * 1e4 ** b == pytest.approx(0.2)
    # 0.2 * (n / 1e4) ** -0.5 = 0.01  ->  n = 1e4 * 20 ** 2
    assert scaling.needed((a, b), 0.99) == pytest.approx(4e6, rel=1e-6)
    # misses that do not fall, or too few points, never reach a floor
    assert scaling.needed(scaling.power_law(sizes, misses[::-1]), 0.99) == float("inf")
    assert scaling.power_law(sizes, np.array([0.1, 0, 0, 0])) is None
    assert scaling.needed(None, 0.99) == float("inf")


def test_a_tiny_curve_runs_resumes_and_fits_runs_of_two_invocations(data, tmp_path,
                                                                     monkeypatch, capsys):
    scaling = _script()
    path = tmp_path / "t.npz"
    save_transitions(path, data)
    out = tmp_path / "out"
    common = ["x", "--data", str(path), "--validation", str(path), "--steps", "3",
              "--fit-sample", "20", "--runs", str(tmp_path / "runs"), "--out", str(out)]
    for sizes in (["10", "20"], ["40", "--reference-size", "800"]):
        monkeypatch.setattr(sys, "argv", common + ["--sizes", *sizes])
        scaling.main()
    rows = json.loads((out / "scaling-s3-w256-seed0.json").read_text())
    assert [r["size"] for r in rows] == [10, 20, 40]
    assert all(0 <= r["unseen"][g]["within"] <= 1 for r in rows for g in ("head", "tail", "both"))
    assert (out / "scaling-s3-w256-seed0.png").stat().st_size > 0
    fit = json.loads((out / "scaling-fit-s3-w256-seed0.json").read_text())
    assert set(fit) == {"head", "tail", "both", "reference"}
    printed = capsys.readouterr().out
    assert "fitted over 3 sizes" in printed and "the shipped model on the same moves" in printed
    # a second run of the same size trains nothing more: its time and scores stand
    before = (tmp_path / "runs" / "n20-s3-w256-seed0" / "scores.json").read_text()
    monkeypatch.setattr(sys, "argv", common + ["--sizes", "20"])
    scaling.main()
    assert (tmp_path / "runs" / "n20-s3-w256-seed0" / "scores.json").read_text() == before
