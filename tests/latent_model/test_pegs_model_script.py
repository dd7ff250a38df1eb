"""benchmarks/pegs_model.py: a model's error around pegs, and the simulator's own replay."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
from scripts import load_script

from dlo_env.dataset.transitions import (
    TransitionCollectConfig,
    collect_transition_chunk,
    load_transitions,
    save_transitions,
)
from latent_model.transition_model import TransitionModelConfig
from latent_model.transition_training import TransitionTrainConfig, train_transition_model


def test_moves_replay_from_their_start_and_the_script_reports_models_and_replays(tmp_path):
    script = load_script("benchmarks/pegs_model.py")
    # Cords of other parameters, another action size and every grasp: the replay must read
    # each from the file.
    collect = TransitionCollectConfig(seed=5, max_pegs=3, max_step=0.03, moves_per_episode=2,
                                      randomize={"friction": [0.2, 0.6], "length": [0.8, 1.2]})
    data = collect_transition_chunk(collect, 0, 30)
    path = save_transitions(tmp_path / "pegs.npz", data)
    data = load_transitions(path)
    can = script.replayable(data)
    first = np.flatnonzero(can & (data.step == 0))
    assert set(data.grasp[first].tolist()) == {0, 1, 2}
    # A move from a fresh start replays to the recorded shape (the simulator is deterministic).
    assert script.replay_errors(data, first).max() < 1e-3
    # ... and not when told another cord: the replay depends on what the file holds.
    heavier = data.params.copy()
    heavier[:, 1:] *= np.float32(3.0)  # stiffness, friction and mass; the length kept
    other = replace(data, params=heavier)
    assert script.replay_errors(other, first).max() > 1e-3
    # A stretched start, or one left by a move that did not come to rest, is left out.
    stretched = replace(data, start=data.start * np.float32(1.05))
    assert not script.replayable(stretched).any()
    second = np.flatnonzero(data.step == 1)
    assert can[second].any()
    moving = replace(data, at_rest=np.where(data.step == 0, False, data.at_rest))
    assert not script.replayable(moving)[second].any()
    config = replace(TransitionModelConfig(), members=2, width=16, depth=1, peg_reach=0.1,
                     cord_inputs=True)
    train_transition_model(data, tmp_path / "m", TransitionTrainConfig(
        steps=2, batch_size=8, eval_every=2), config)
    assert script.main(["--model", str(tmp_path / "m" / "transition.pt"), "--data", str(path),
                        "--out", str(tmp_path / "out"), "--replay", "2"]) == 0
    results = json.loads((tmp_path / "out" / "results.json").read_text())
    assert results["replay"] and set(results["replay"]) <= {"touching", "untouched"}
    for row in results["replay"].values():
        assert row["count"] <= 2 and row["mean_cm"] >= 0.0
