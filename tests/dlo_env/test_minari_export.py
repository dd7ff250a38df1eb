"""Specification: the oracle demonstrations and the transition data round-trip through Minari:
``minari.load_dataset`` finds them, ``recover_environment`` makes a working environment (in a
fresh process too), and replaying an episode's actions reaches the recorded shapes and goal."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from dlo_env.dataset.minari_export import (
    demonstrations_id,
    export_demonstrations,
    export_transitions,
    minari_root,
    transitions_id,
)
from dlo_env.dataset.transitions import TransitionCollectConfig, collect_transitions
from dlo_env.tasks import load_suite

minari = pytest.importorskip("minari", reason='needs the minari extra: pip install -e ".[minari]"')
pytest.importorskip("h5py", reason='needs the minari extra: pip install -e ".[minari]"')

ENDPOINT, DUAL = "dlo_env/DLOEndpoint-v0", "dlo_env/DLODualEndpoint-v0"


def replay(env, episode) -> tuple[np.ndarray, dict]:
    """Reset ``env`` to the episode's start and goal, run its actions; the achieved shapes."""
    obs = episode.observations
    env.reset(options={"start": obs["achieved_goal"][0], "goal": obs["desired_goal"][0]})
    shapes, info = [], {}
    for action in episode.actions:
        new, _, _, _, info = env.step(action)
        shapes.append(new["achieved_goal"])
    return np.array(shapes), info


@pytest.mark.parametrize(("env_id", "suite"), [(ENDPOINT, "linear-2"), (DUAL, "linear-1")])
def test_demonstrations_load_recover_and_replay_to_their_goals(env_id, suite, tmp_path):
    exported = export_demonstrations(env_id, suite, root=tmp_path, limit=3)
    assert exported.dataset_id == demonstrations_id(env_id, suite)
    assert (exported.episodes, exported.solved) == (3, 3)
    tasks = load_suite(suite, "train", grasp="head" if env_id == ENDPOINT else "both", limit=3)
    with minari_root(tmp_path):
        dataset = minari.load_dataset(exported.dataset_id)
        env = dataset.recover_environment()
        assert env.spec.id == env_id and dataset.total_episodes == 3
        for task, episode in zip(tasks, dataset.iterate_episodes()):
            np.testing.assert_array_equal(episode.observations["desired_goal"][0],
                                          task.goal.reshape(-1))
            np.testing.assert_array_equal(episode.actions,
                                          task.reference_actions[:len(episode.actions)])
            shapes, info = replay(env, episode)
            assert info["is_success"] and episode.terminations[-1]
            np.testing.assert_allclose(shapes, episode.observations["achieved_goal"][1:],
                                       atol=1e-6)


def test_a_fresh_process_recovers_the_environment_without_importing_dlo_env(tmp_path):
    exported = export_demonstrations(ENDPOINT, "linear-1", root=tmp_path, limit=1)
    code = textwrap.dedent(f"""
        import sys
        import minari

        dataset = minari.load_dataset({exported.dataset_id!r})
        env = dataset.recover_environment()
        episode = dataset[0]
        obs = episode.observations
        env.reset(options={{"start": obs["achieved_goal"][0], "goal": obs["desired_goal"][0]}})
        for action in episode.actions:
            *_, info = env.step(action)
        print(env.spec.id, bool(info["is_success"]), "dlo_env" in sys.modules)
    """)
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            cwd=tmp_path, timeout=300,
                            env={**os.environ, "MINARI_DATASETS_PATH": str(tmp_path)})
    assert result.returncode == 0, result.stderr[-3000:]
    # dlo_env was imported by Gymnasium from the recorded entry point, not by the script.
    assert result.stdout.split() == ["dlo_env/DLOEndpoint-v0", "True", "True"]


def test_transition_data_exports_per_environment_and_replays_move_by_move(tmp_path):
    data = collect_transitions(tmp_path / "t.npz", 40, TransitionCollectConfig(seed=3))
    exported = export_transitions(tmp_path / "t.npz", root=tmp_path / "minari")
    assert [d.dataset_id for d in exported] == [transitions_id(ENDPOINT), transitions_id(DUAL)]
    held = {ENDPOINT: 0, DUAL: 2}  # grasp codes: head, both (tail-held episodes are left out)
    for d, (env_id, grasp) in zip(exported, held.items()):
        assert d.steps == int((data.grasp == grasp).sum()) and d.replay_error < 1e-6
        with minari_root(tmp_path / "minari"):
            dataset = minari.load_dataset(d.dataset_id)
            env = dataset.recover_environment()
        assert env.spec.id == env_id
        assert [w.name for w in env.spec.additional_wrappers] == ["StraightMoves"]
        episode = dataset[0]
        first = data.subset(data.episode == np.unique(data.episode[data.grasp == grasp])[0])
        np.testing.assert_allclose(episode.actions[:, :2], first.displacement[:, 0], atol=0)
        shapes, _ = replay(env, episode)
        np.testing.assert_allclose(shapes.reshape(first.next.shape), first.next, atol=1e-5)


def test_transition_data_among_pegs_exports_with_its_pegs(tmp_path):
    data = collect_transitions(tmp_path / "t.npz", 60, TransitionCollectConfig(seed=1,
                                                                              max_pegs=3))
    assert data.peg_count.any()
    exported = export_transitions(tmp_path / "t.npz", root=tmp_path / "minari")
    assert all(d.replay_error < 1e-6 for d in exported)
    with minari_root(tmp_path / "minari"):
        dataset = minari.load_dataset(transitions_id(ENDPOINT))
        env = dataset.recover_environment()
    assert env.unwrapped.max_pegs == 3
    head = data.subset(data.grasp == 0)
    counts = []
    for episode, first in zip(dataset.iterate_episodes(), np.unique(head.episode)):
        rows = np.flatnonzero(head.episode == first)
        pegs = episode.observations["observation"][0][-9:]  # 3 slots: x, y per peg, then mask
        count = int(head.peg_count[rows[0]])
        counts.append(count)
        np.testing.assert_allclose(pegs[:2 * count], head.peg_list(rows[0]).reshape(-1))
        assert pegs[6:6 + count].all() and not pegs[6 + count:].any()
    assert max(counts) > 0  # some head-held episode stood among pegs


def test_an_existing_dataset_is_an_error_not_an_overwrite(tmp_path):
    export_demonstrations(ENDPOINT, "linear-1", root=tmp_path, limit=1)
    with pytest.raises(ValueError, match="already exists"):
        export_demonstrations(ENDPOINT, "linear-1", root=tmp_path, limit=1)


def test_the_command_refuses_what_it_cannot_write_before_it_records_an_episode(tmp_path,
                                                                             capsys):
    from dlo_cli.main import main

    export_demonstrations(ENDPOINT, "linear-2", root=tmp_path, limit=1)
    text = tmp_path / "notes.txt"
    text.write_text("the user's notes")
    for argv, words in (
            (["--suite", "linear-1", "linear-2"], "'dlo/endpoint/linear-2-oracle-v0' already "
                                                  "exists"),
            (["--suite", "linear-1", "--transitions", str(text)],
             f"--transitions: '{text}' is not a readable .npz transition dataset (corrupt"),
            (["--suite", "linear-1", "--transitions", str(text), "--name", "a/b"], "--name: "),
            (["--suite", "linear-1", "--transitions", str(text), "--name", "my.data"],
             "--name: "),
            (["--root", str(text)], "--root must be a folder, got the file")):
        argv = ["export-minari", "--root", str(tmp_path), "--env", ENDPOINT, "--limit", "1",
                *argv]
        assert main(argv) == 2
        captured = capsys.readouterr()
        assert captured.out == "" and len(captured.err.strip().splitlines()) == 1, captured.err
        assert captured.err.startswith("dlo export-minari: error: ") and words in captured.err
    with minari_root(tmp_path):  # linear-1 was never written
        assert list(minari.list_local_datasets()) == [demonstrations_id(ENDPOINT, "linear-2")]
    assert text.read_text() == "the user's notes"


def test_export_minari_command_prints_one_line_per_dataset(tmp_path, capsys):
    from dlo_cli.main import main

    assert main(["export-minari", "--root", str(tmp_path), "--suite", "linear-1",
                 "--env", ENDPOINT, "--limit", "2"]) == 0
    out = capsys.readouterr().out
    assert "dlo/endpoint/linear-1-oracle-v0: 2 episodes" in out
    metadata = json.loads((tmp_path / "dlo/endpoint/linear-1-oracle-v0/data/metadata.json")
                          .read_text())
    assert metadata["algorithm_name"] == "oracle"
