"""``dlo baseline`` and scoring its models (and the physics planner) with ``dlo evaluate``."""

from __future__ import annotations

import json

import pytest

from dlo_cli.main import main

TINY_FLAGS = ["--timesteps", "128", "--n-envs", "1", "--set", "net_arch=[16,16]",
              "ppo_n_steps=64", "ppo_batch_size=32", "ppo_epochs=1", "checkpoint_every=0"]


@pytest.mark.slow
def test_baseline_trains_and_evaluate_scores_the_saved_model(tmp_path, capsys):
    folder = tmp_path / "ppo"
    assert main(["baseline", "--algo", "ppo", *TINY_FLAGS, "--out", str(folder)]) == 0
    printed = capsys.readouterr().out
    assert "done: 128 steps" in printed
    meta = json.loads((folder / "hyperparameters.json").read_text())
    assert meta["config"]["net_arch"] == [16, 16] and meta["config"]["difficulties"] == [1, 2, 3]
    out = tmp_path / "eval"
    assert main(["evaluate", "--agent", f"sb3:{folder}", "--episodes", "1", "--out",
                 str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary[0]["agent"] == f"sb3:{folder}" and summary[0]["episodes"] == 1


@pytest.mark.slow
def test_evaluate_runs_the_physics_planner(tmp_path):
    out = tmp_path / "eval"
    assert main(["evaluate", "--agent", "physics-mpc", "--episodes", "1", "--out",
                 str(out)]) == 0
    record = json.loads((out / "physics-mpc-d1.json").read_text())["records"][0]
    assert record["plans"] >= 1 and record["planning_seconds"] > 0


@pytest.mark.slow
def test_baseline_writes_by_default_where_the_benchmark_looks(tmp_path, monkeypatch, capsys):
    """Without --out, a baseline trained in the dual environment with pegs lands in the folder
    that ``dlo benchmark`` reads for it (``baseline_folder_name``)."""
    import dlo_bench.paths
    from dlo_bench.paths import baseline_folder_name

    monkeypatch.setattr(dlo_bench.paths, "RUNS_DIR", tmp_path / "runs")
    env = "dlo_env/DLODualEndpoint-v0"
    assert main(["baseline", "--algo", "ppo", *TINY_FLAGS, "--env", env, "--max-pegs", "2"]) == 0
    folder = tmp_path / "runs" / "baseline" / "ppo-pegs-dual-endpoint"
    assert folder.name == baseline_folder_name("ppo", env, pegs=True)
    assert (folder / "model.zip").is_file()
    assert str(folder) in capsys.readouterr().out


def test_baseline_rejects_an_unknown_setting(tmp_path, capsys):
    code = main(["baseline", "--algo", "ppo", "--set", "learning_rte=0.1", "--out",
                 str(tmp_path)])
    assert code == 2
    assert "--set learning_rte: unknown key" in capsys.readouterr().err


def test_evaluate_reports_a_folder_without_a_baseline(tmp_path, capsys):
    code = main(["evaluate", "--agent", f"sb3:{tmp_path}", "--out", str(tmp_path / "eval")])
    assert code == 2
    assert "holds no model.zip" in capsys.readouterr().err
