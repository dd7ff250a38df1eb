"""Benchmark cells in local worker processes (dlo_env.dataset.process_backend, --jobs)."""

from __future__ import annotations

import json
import operator

import pytest

from dlo_cli.main import main
from dlo_env.dataset.process_backend import ProcessBackend


def test_map_yields_every_result_with_its_index_and_raises_a_calls_error():
    calls = [(2, 3), (4, 5), (6, 7)]
    assert sorted(ProcessBackend(2).map(operator.mul, calls)) == [(0, 6), (1, 20), (2, 42)]
    with pytest.raises(ZeroDivisionError):
        list(ProcessBackend(2).map(operator.truediv, [(1, 1), (1, 0)]))
    with pytest.raises(ValueError, match="workers must be an int >= 1"):
        ProcessBackend(0)


def test_benchmark_cells_in_two_processes_equal_the_local_ones(tmp_path, capsys):
    args = ["benchmark", "--agent", "straight-line", "--env", "DLOEndpoint-v0", "--difficulty",
            "1", "2", "--episodes", "2", "--threshold", "0.02", "--allow-dirty"]
    assert main([*args, "--out", str(tmp_path / "one")]) == 0
    assert main([*args, "--out", str(tmp_path / "two"), "--jobs", "2"]) == 0
    for cell in ("straight-line-endpoint-d1-2cm", "straight-line-endpoint-d2-2cm"):
        one, two = (json.loads((tmp_path / run / "results_episodes" / f"{cell}.json")
                               .read_text()) for run in ("one", "two"))
        assert one["summary"]["success_rate"] == two["summary"]["success_rate"]
        assert [r["final_error"] for r in one["records"]] == \
            [r["final_error"] for r in two["records"]]
    capsys.readouterr()
    assert main([*args, "--out", str(tmp_path / "x"), "--jobs", "2", "--backend", "ray"]) == 2
    assert "--jobs runs the cells in local processes" in capsys.readouterr().err
