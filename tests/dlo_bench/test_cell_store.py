"""Benchmark cells as compressed arrays: written and read back value for value."""

from __future__ import annotations

import json

import numpy as np
import pytest

from dlo_bench.cell_store import find_cell, read_cell, write_cell


def _cell(rng: np.random.Generator, episodes: int = 6) -> dict:
    """A cell as the benchmark writes one: records with missing floats, profiles (one of them
    with float moves, as an old version wrote), and the shapes of a peg suite."""
    records = [{"episode": i, "seed": -1, "task_seed": 1000 + i, "success": bool(i % 2),
                "final_error": float(rng.random()), "seconds": float(rng.random()),
                "planning_seconds": float(rng.random()),
                "fidelity": None if i % 3 else float(rng.random())} for i in range(episodes)]
    profiles = [{"episode": i, "errors": rng.random(i + 1).tolist(),
                 "travel": rng.random(i + 1).tolist(),
                 "move": [float(m) for m in range(i + 1)] if i == 1 else list(range(i + 1))}
                for i in range(3)]
    points = [rng.random((5 + i, 2)).astype(np.float32).tolist() for i in range(episodes)]
    return {"summary": {"agent": "x", "success_rate": 0.5, "divergence": {"by_move": {"1": 0.1}}},
            "records": records, "fidelity_profiles": profiles,
            "benchmark_key": {"agent": "x", "episodes": episodes}, "wall_seconds": 1.5,
            "commit": "abc1234", "run": "r", "machine": "m",
            "shapes": {"seeds": list(range(episodes)), "families": ["pegs-1"] * episodes,
                       "pegs": [rng.random((i % 3, 2)).tolist() for i in range(episodes)],
                       "peg_radius": [0.02] * episodes, "goals": points,
                       "rest": [(np.asarray(p) + 0.01).tolist() for p in points]}}


def test_a_cell_reads_back_value_for_value_and_in_order(tmp_path):
    cell = _cell(np.random.default_rng(0))
    path = write_cell(tmp_path / "c.npz", cell)
    back = read_cell(path)
    assert json.dumps(back) == json.dumps(cell)  # same values, types (1 vs 1.0) and key order
    part = {"summary": cell["summary"], "records": cell["records"][:2], "fidelity_profiles": [],
            "goals": cell["shapes"]["goals"][:2], "rest": cell["shapes"]["rest"][:2]}
    assert json.dumps(read_cell(write_cell(tmp_path / "p.npz", part))) == json.dumps(part)


def test_a_cell_is_a_plain_npz_written_the_same_twice_and_smaller_than_json(tmp_path):
    cell = _cell(np.random.default_rng(1), episodes=50)
    a, b = write_cell(tmp_path / "a.npz", cell), write_cell(tmp_path / "b.npz", cell)
    assert a.read_bytes() == b.read_bytes()
    with np.load(a, allow_pickle=False) as data:
        assert data["records_float_time"].shape == (2, 50)  # the times, a member of their own
    assert a.stat().st_size < 0.5 * len(json.dumps(cell, indent=2))


def test_an_older_json_cell_is_found_and_read_and_a_bad_file_is_refused(tmp_path):
    cell = _cell(np.random.default_rng(2))
    (tmp_path / "old.json").write_text(json.dumps(cell))
    assert find_cell(tmp_path, "old") == tmp_path / "old.json"
    assert read_cell(find_cell(tmp_path, "old")) == cell
    write_cell(tmp_path / "old.npz", cell)
    assert find_cell(tmp_path, "old") == tmp_path / "old.npz"
    assert find_cell(tmp_path, "none") is None
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="bad.npz is not a benchmark cell"):
        read_cell(tmp_path / "bad.npz")
