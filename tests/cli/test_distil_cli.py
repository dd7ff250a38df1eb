"""``dlo distil`` and the network it writes, evaluated with ``dlo evaluate --network``."""

from __future__ import annotations

import json

import pytest

from dlo_cli.main import main


@pytest.mark.slow
def test_distil_writes_a_network_per_environment_that_evaluate_runs(tmp_path, capsys):
    out = tmp_path / "distil"
    code = main(["distil", "--env", "DLOEndpoint-v0", "DLODualEndpoint-v0", "--difficulty", "1",
                 "--rounds", "1", "--tasks", "2", "--horizon", "1", "--epochs", "1",
                 "--width", "8", "--out", str(out)])
    assert code == 0
    for folder in ("latent-mpc-distilled", "latent-mpc-distilled-dual-endpoint"):
        assert (out / folder / "distilled.pt").is_file()
        assert (out / folder / "distil-state.pt").is_file()
    capsys.readouterr()
    evaluated = tmp_path / "evaluate"
    code = main(["evaluate", "--agent", "latent-mpc-distilled", "--network",
                 str(out / "latent-mpc-distilled-dual-endpoint"), "--env", "DLODualEndpoint-v0",
                 "--difficulty", "1", "--episodes", "1", "--out", str(evaluated)])
    assert code == 0
    text = json.dumps(json.loads((evaluated / "summary.json").read_text()))
    assert "latent-mpc-distilled-dual-endpoint/distilled.pt" in text


def test_distil_refuses_a_bad_flag_in_one_line(capsys):
    assert main(["distil", "--tasks", "0"]) != 0
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "--tasks" in err and "positive integer" in err
