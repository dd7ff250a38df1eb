"""The misses-by-rim script (benchmarks/transition_misses.py) bands moves and counts misses."""

from __future__ import annotations

import sys

import numpy as np
from scripts import load_script

from dlo_env.dataset.transitions import (
    TransitionCollectConfig,
    collect_transition_chunk,
    save_transitions,
)
from latent_model.transition_model import TransitionModel, TransitionModelConfig


def _script():
    return load_script("benchmarks/transition_misses.py")


def test_the_rim_distance_is_the_nearest_point_of_either_shape():
    misses = _script()
    a = np.zeros((2, 3, 2), dtype=np.float32)
    b = np.zeros((2, 3, 2), dtype=np.float32)
    a[0, 1] = (0.995, 0.0)  # touching the right wall
    b[1, 2] = (0.0, -0.97)  # 3 cm from the bottom, in the result only
    assert np.allclose(misses.rim_distance(a, b), [0.005, 0.03], atol=1e-6)


def test_every_move_is_counted_once_in_its_band(tmp_path, monkeypatch, capsys):
    misses = _script()
    data = collect_transition_chunk(TransitionCollectConfig(seed=5, rim_fraction=0.5), 0, 40)
    path = save_transitions(tmp_path / "t.npz", data)
    model = TransitionModel(TransitionModelConfig(width=8, depth=1, members=2), device="cpu")
    model.save(tmp_path / "m.pt")
    monkeypatch.setattr(sys, "argv", ["transition_misses.py", "--model", str(tmp_path / "m.pt"),
                                      "--file", str(path)])
    misses.main()
    rows = [line.split() for line in capsys.readouterr().out.splitlines()[2:]]
    for code, end in enumerate(("head", "tail", "both")):
        mine = [r for r in rows if r[0] == end]
        if not (data.grasp == code).any():
            assert not mine
            continue
        total = next(r for r in mine if r[1] == "all")
        assert int(total[2]) == (data.grasp == code).sum()
        bands = [r for r in mine if r[1] != "all"]
        assert sum(int(r[-4]) for r in bands) == int(total[2])  # moves
        assert sum(int(r[-3]) for r in bands) == int(total[3])  # misses
