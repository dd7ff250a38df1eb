from __future__ import annotations

import json
from pathlib import Path

import pytest

from dlo_cli.main import main

PRETRAINED = Path(__file__).resolve().parents[2] / "latent_model" / "pretrained" / "model.pt"


def _check_outputs(out: Path, rows: int) -> None:
    assert (out / "episode.gif").stat().st_size > 0
    assert (out / "interpolation.png").stat().st_size > 0
    summary = json.loads((out / "summary.json").read_text())
    assert len(summary) == rows
    assert {row["agent"] for row in summary} == {"straight-line", "latent-tree",
                                                 "latent-tree-closed", "latent-mpc"}


@pytest.mark.slow
def test_demo_writes_the_table_the_episode_gif_and_the_interpolation_png(tmp_path, capsys):
    from latent_model import ShapeModel
    from latent_model.config import ModelConfig
    from latent_model.normalisation import Normalisation

    model = tmp_path / "untrained.pt"  # random weights: tests the job, not the model
    ShapeModel(ModelConfig(), Normalisation(), device="cpu").save(model)
    out = tmp_path / "demo"
    code = main(["demo", "--model", str(model), "--episodes", "1", "--difficulty", "1",
                 "--out", str(out)])
    assert code == 0
    printed = capsys.readouterr().out
    assert "latent-tree-closed" in printed and "latent-mpc" in printed
    assert "success: the cord at rest within 1 cm" in printed  # judged as the README says
    assert "episode.gif: latent-mpc on linear-5 test task" in printed
    _check_outputs(out, rows=4)


@pytest.mark.slow
@pytest.mark.skipif(not PRETRAINED.is_file(),
                    reason="latent_model/pretrained/model.pt is not shipped yet")
def test_demo_runs_on_the_shipped_model(tmp_path):
    out = tmp_path / "demo"
    code = main(["demo", "--episodes", "1", "--difficulty", "1", "2", "--out", str(out)])
    assert code == 0
    _check_outputs(out, rows=8)


@pytest.mark.slow
def test_the_demo_gif_shows_latent_mpc_solving_a_linear_5_task(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--episodes", "1", "--difficulty", "1", "--out", str(out)]) == 0
    line = next(row for row in capsys.readouterr().out.splitlines()
                if row.startswith("episode.gif:"))
    assert "latent-mpc on linear-5" in line and ", solved," in line
