"""The misses-by-rim script (benchmarks/transition_misses.py) bands moves and counts misses."""

from __future__ import annotations

import sys

import numpy as np
import torch
from scripts import load_script

from dlo_env.dataset.transitions import (
    TransitionCollectConfig,
    TransitionDataset,
    collect_transition_chunk,
    save_transitions,
)
from dlo_env.shapes import error
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
    data = collect_transition_chunk(TransitionCollectConfig(seed=5), 0, 60)
    # Each transition shifted so that its nearest point is 0.5, 3 or 20 cm from the right edge.
    gap = np.resize(np.float32([0.005, 0.03, 0.2]), len(data))
    reach = np.maximum(data.start[..., 0].max(axis=1), data.next[..., 0].max(axis=1))
    shift = np.zeros((len(data), 1, 2), dtype=np.float32)
    shift[:, 0, 0] = 1.0 - gap - reach
    data = TransitionDataset(**{**data.arrays(), "start": data.start + shift,
                                "next": data.next + shift}, metadata=data.metadata)
    path = save_transitions(tmp_path / "t.npz", data)
    torch.manual_seed(0)  # the same random model whatever ran before
    model = TransitionModel(TransitionModelConfig(width=8, depth=1, members=2), device="cpu")
    with torch.no_grad():
        model.net.weights[-1].mul_(30.0)  # misses of every size
    model.save(tmp_path / "m.pt", half=False)
    monkeypatch.setattr(sys, "argv", ["transition_misses.py", "--model", str(tmp_path / "m.pt"),
                                      "--file", str(path)])
    misses.main()
    rows = {(r[0], " ".join(r[1:-4])): r[-4:] for r in (
        line.split() for line in capsys.readouterr().out.splitlines()[2:])}
    labels = {0.005: "under 1 cm", 0.03: "1-5 cm", 0.2: "5 cm or more"}
    missed = 0
    for code, end in enumerate(("head", "tail", "both")):
        idx = np.flatnonzero(data.grasp == code)
        assert len(idx), "the chunk holds every grasp"
        e = error(model.predict(data.start[idx], end, data.end_displacement(idx)),
                  data.next[idx])
        for g, label in labels.items():  # counted here without the script's helpers
            mine = np.isclose(gap[idx], g)
            assert rows[(end, label)][:2] == [str(mine.sum()), str((e[mine] > 0.01).sum())]
        assert rows[(end, "all")][:2] == [str(len(idx)), str((e > 0.01).sum())]
        missed += (e > 0.01).sum()
    assert 0 < missed < len(data)  # both kinds of move are counted


def test_the_report_prints_a_dash_for_a_group_without_held_out_moves():
    from latent_model.transition_metrics import ErrorRow, report_lines

    nan = float("nan")
    lines = report_lines([ErrorRow(1, "head", 0, nan, nan, nan, nan),
                          ErrorRow(1, "tail", 4, 0.1, 0.1, 0.2, 1.0, 0.05, 0.15)], 0.5)
    assert "nan" not in lines[1] and lines[1].split()[-1] == "-"
    assert "0.100cm" in lines[2]
