"""The collection profile of benchmarks/transition_throughput.py: its step accounting and replay."""

from __future__ import annotations

import numpy as np
from scripts import ROOT, load_script

from dlo_env.dataset.transitions import TransitionCollectConfig, collect_transition_chunk


def test_the_phases_add_up_to_every_physics_step_and_a_replay_repeats_the_moves(
        monkeypatch, capsys):
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))  # it imports the script beside it
    script = load_script("benchmarks/transition_throughput.py")
    config = TransitionCollectConfig(seed=5, moves_per_episode=3)
    with script.physics_timer() as spent, script.settle_steps() as settling:
        data = collect_transition_chunk(config, 0, 6)
    resting = int(data.settle.astype(np.int64).sum()) * config.cord.substeps
    moving = spent[1] - resting - settling[0]
    assert settling[0] > 0 and resting > 0
    # every move lasts whole control periods of substeps, at least one per action
    assert moving > 0 and moving % config.cord.substeps == 0
    same, _ = script.replay(config, data, config.cord.iterations)
    assert np.abs(same - data.next).max() < 1e-3  # the recorded moves, carried out again
    script.solver_tradeoff(config, data.subset(np.arange(len(data)) < 2), [10])
    out = capsys.readouterr().out
    assert "replaying 2 moves" in out and "10 iterations:" in out
