from __future__ import annotations

import json
from pathlib import Path

import pytest

from dlo_cli.main import main


@pytest.fixture
def untrained_model_file(tmp_path):
    """A ShapeModel checkpoint with random weights: the plumbing, not the quality, is tested."""
    from latent_model import ShapeModel
    from latent_model.config import ModelConfig
    from latent_model.normalisation import Normalisation

    path = tmp_path / "untrained.pt"
    ShapeModel(ModelConfig(), Normalisation(), device="cpu").save(path)
    return path


def test_evaluate_prints_the_table_and_writes_csv_and_json(tmp_path, capsys):
    out = tmp_path / "eval"
    code = main(["evaluate", "--agent", "straight-line", "--difficulty", "1", "2",
                 "--episodes", "2", "--out", str(out)])
    assert code == 0
    printed = capsys.readouterr().out
    assert "straight-line" in printed and "success" in printed
    for name in ("straight-line-d1", "straight-line-d2"):
        assert (out / f"{name}.csv").is_file()
        data = json.loads((out / f"{name}.json").read_text())
        assert data["summary"]["episodes"] == 2 and len(data["records"]) == 2
    summary = json.loads((out / "summary.json").read_text())
    assert [row["difficulty"] for row in summary] == [1, 2]


@pytest.mark.slow
def test_evaluate_runs_the_latent_tree_agents_on_a_given_model(tmp_path, untrained_model_file,
                                                              capsys):
    out = tmp_path / "eval"
    code = main(["evaluate", "--agent", "latent-tree", "latent-tree-closed", "--episodes", "1",
                 "--model", str(untrained_model_file), "--max-seconds", "0.05",
                 "--replan-every", "50", "--out", str(out)])
    assert code == 0
    for name in ("latent-tree-d1", "latent-tree-closed-d1"):
        data = json.loads((out / f"{name}.json").read_text())
        record = data["records"][0]
        assert record["plans"] >= 1
        assert record["planning_seconds"] > 0
        assert len(data["fidelity_profiles"]) == 1
    printed = capsys.readouterr().out
    assert "where plans and the real cord part ways" in printed
    assert "travel 0-5 cm" in printed


def test_evaluate_records_the_model_files_each_agent_planned_with(tmp_path, capsys):
    """latent-mpc among pegs loads the shipped model that sees pegs unless told another; the
    summary names it (and names none for an agent without a model)."""
    out = tmp_path / "eval"
    code = main(["evaluate", "--agent", "latent-mpc", "straight-line", "--suite", "pegs-1",
                 "--episodes", "1", "--no-fidelity", "--out", str(out)])
    assert code == 0
    models = {row["agent"]: row["models"]
              for row in json.loads((out / "summary.json").read_text())}
    assert [Path(f).name for f in models["latent-mpc"]] == ["transition-pegs.pt"]
    assert models["straight-line"] == []
    given = Path(__file__).parents[2] / "latent_model" / "pretrained" / "transition.pt"
    code = main(["evaluate", "--agent", "latent-mpc", "--suite", "pegs-1", "--episodes", "1",
                 "--no-fidelity", "--transition-model", str(given), "--out", str(out)])
    assert code == 0
    row = json.loads((out / "summary.json").read_text())[0]
    assert row["models"] == [str(given)]


@pytest.mark.slow
def test_evaluate_records_the_policy_file_of_an_rl_agent(tmp_path):
    from dlo_bench.paths import shipped_baseline

    out = tmp_path / "eval"
    folder = shipped_baseline("ppo")
    assert main(["evaluate", "--agent", "ppo", f"sb3:{folder}", "--episodes", "1",
                 "--no-fidelity", "--out", str(out)]) == 0
    rows = json.loads((out / "summary.json").read_text())
    assert [row["models"] for row in rows] == [[str(folder / "policy.pt")]] * 2


def test_evaluate_rejects_an_unknown_agent(tmp_path, capsys):
    code = main(["evaluate", "--agent", "teleport", "--out", str(tmp_path)])
    assert code == 2
    assert "agent name must be one of" in capsys.readouterr().err


def test_evaluate_reports_a_missing_model_file(tmp_path, capsys):
    code = main(["evaluate", "--agent", "latent-tree", "--model", str(tmp_path / "none.pt"),
                 "--out", str(tmp_path)])
    assert code == 2
    assert "no shape model" in capsys.readouterr().err
