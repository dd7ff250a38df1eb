"""Benchmark cells run in parts of episodes (dlo benchmark --part-episodes): the same cell."""

from __future__ import annotations

from dataclasses import replace

import pytest

from dlo_bench.agents import build_agent
from dlo_bench.benchmark import (
    PARTS_DIR,
    BenchmarkConfig,
    machine_label,
    run_benchmark,
    split_episodes,
)
from dlo_bench.cell_store import read_cell
from dlo_bench.evaluation import evaluate

TIMINGS = {"seconds", "planning_seconds"}
ENDPOINT = "dlo_env/DLOEndpoint-v0"


def _untimed(records: list[dict]) -> list[dict]:
    return [{k: v for k, v in r.items() if k not in TIMINGS} for r in records]


def _cells(folder) -> dict[str, dict]:
    return {p.stem: read_cell(p) for p in (folder / "results_episodes").glob("*.npz")}


def test_evaluate_from_a_first_episode_runs_those_episodes_of_the_whole():
    import gymnasium as gym

    with gym.make(ENDPOINT) as env:
        policy = build_agent("straight-line", env)
        whole = evaluate(policy, env, suite="linear-2", episodes=4, fidelity=False)
        tail = evaluate(policy, env, suite="linear-2", episodes=2, first=2, fidelity=False)
        seeded = evaluate(policy, env, episodes=1, first=3, seed=5, fidelity=False)
    assert [r.episode for r in tail.records] == [2, 3]
    for a, b in zip(whole.records[2:], tail.records):
        assert (a.task_seed, a.final_error, a.rest_error, a.steps) == \
            (b.task_seed, b.final_error, b.rest_error, b.steps)
    assert seeded.records[0].seed == 8  # seed + episode index
    with pytest.raises(ValueError, match="first must be an int >= 0"):
        evaluate(policy, ENDPOINT, episodes=1, first=-1)


def test_a_bad_part_size_is_a_one_line_error(tmp_path):
    config = BenchmarkConfig(agents=("straight-line",), envs=(ENDPOINT,), difficulties=(1,),
                             thresholds=(0.02,), designed=(), episodes=1)
    for part in (0, -2, 1.5, True):
        with pytest.raises(ValueError, match="part must be an int >= 1"):
            run_benchmark(config, tmp_path, progress=False, part=part)


def test_parts_of_another_part_size_are_deleted_with_their_cell(tmp_path):
    config = BenchmarkConfig(agents=("straight-line",), envs=(ENDPOINT,), difficulties=(1,),
                             thresholds=(0.02,), designed=(), episodes=2)
    stale = tmp_path / "results_episodes" / PARTS_DIR
    stale.mkdir(parents=True)
    (stale / "straight-line-endpoint-d1-2cm.episodes-0-4.npz").write_text("{}")
    (stale / "straight-line-endpoint-d1-2cm.episodes-0-4.json").write_text("{}")  # an older one
    (stale / "other-cell.episodes-0-4.npz").write_text("{}")
    run_benchmark(config, tmp_path, progress=False, part=1)
    assert [p.name for p in stale.iterdir()] == ["other-cell.episodes-0-4.npz"]


def test_split_episodes_covers_the_cell_in_order():
    assert split_episodes(50, None) == [(0, 50)]
    assert split_episodes(5, 2) == [(0, 2), (2, 2), (4, 1)]
    assert split_episodes(4, 10) == [(0, 4)]


class _StopAfter:
    """A backend that runs calls in this process and stops (as Ctrl-C would) after some."""

    def __init__(self, stop_after: int | None = None):
        self.stop_after, self.calls = stop_after, 0

    def map(self, function, calls):
        for i, args in enumerate(calls):
            if self.stop_after is not None and self.calls == self.stop_after:
                raise KeyboardInterrupt
            self.calls += 1
            yield i, function(*args)


def test_a_cell_in_parts_equals_the_whole_cell_and_resumes_from_its_finished_parts(tmp_path):
    config = BenchmarkConfig(agents=("straight-line", "latent-mpc"), envs=(ENDPOINT,),
                             difficulties=(2,), thresholds=(0.02,), designed=("shapes-curves",),
                             episodes=3)
    run_benchmark(config, tmp_path / "whole", progress=False)
    whole = _cells(tmp_path / "whole")
    assert len(whole) == 4

    # Parts of 2 episodes: the run stops after three parts, then resumes from them.
    with pytest.raises(KeyboardInterrupt):
        run_benchmark(config, tmp_path / "parts", progress=False, part=2,
                      backend=_StopAfter(3))
    kept = sorted(p.name for p in (tmp_path / "parts" / "results_episodes" / PARTS_DIR)
                  .glob("*.npz"))
    assert kept == ["latent-mpc-endpoint-d2-2cm.episodes-0-1.npz"]
    assert list(_cells(tmp_path / "parts")) == ["straight-line-endpoint-d2-2cm"]
    resumed = _StopAfter()
    rows = run_benchmark(config, tmp_path / "parts", progress=False, part=2, resume=True,
                         backend=resumed)
    assert resumed.calls == 8 - 3  # (2 agents x 2 cells x 2 parts) less the three kept
    assert not (tmp_path / "parts" / "results_episodes" / PARTS_DIR).exists()
    parts = _cells(tmp_path / "parts")
    assert sorted(parts) == sorted(whole)
    for cell, a in whole.items():
        b = parts[cell]
        assert _untimed(a["records"]) == _untimed(b["records"]), cell
        assert a["summary"]["success_rate"] == b["summary"]["success_rate"]
        assert a["summary"]["divergence"] == b["summary"]["divergence"]
        assert a["summary"]["suite"] == b["summary"]["suite"] != ""
        assert a["fidelity_profiles"] == b["fidelity_profiles"]
        assert a.get("shapes") == b.get("shapes")
        assert a["benchmark_key"] == b["benchmark_key"]
    # The resumed cell ran its parts in two runs (its planning times are compared with none).
    resumed_cell = parts["latent-mpc-endpoint-d2-2cm"]
    assert "+" in resumed_cell["run"] and resumed_cell["wall_seconds"] > 0
    assert resumed_cell["machine"] == machine_label() and " CPUs" in machine_label()
    assert "+" not in parts["latent-mpc-endpoint-shapes-curves-2cm"]["run"]
    assert [row["agent"] for row in rows] == ["straight-line"] * 2 + ["latent-mpc"] * 2


def test_the_report_names_the_machine_of_each_run():
    from dlo_bench.benchmark_report import run_summary

    rows = [{"status": "ok", "run": "R1", "machine": "A x 2 CPUs"},
            {"status": "ok", "run": "R1", "machine": "A x 2 CPUs"},
            {"status": "ok", "run": "R2", "machine": "B x 16 CPUs"},
            {"status": "ok", "run": "R0"}, {"status": "missing", "run": ""}]
    assert run_summary(rows) == ("R1 (2 cells) on A x 2 CPUs; R2 (1 cell) on B x 16 CPUs; "
                                 "R0 (1 cell) on machine not recorded")


def test_letters_cells_name_the_model_of_their_cord_and_an_agent_without_one_is_a_missing_row(
        tmp_path):
    from dlo_bench.paths import transition_model_file
    from dlo_env.core.atomic import file_digest
    from dlo_env.designed_suites import designed_suite_cord

    config = BenchmarkConfig(agents=("latent-mpc", "latent-tree-kino"), envs=(ENDPOINT,),
                             difficulties=(), thresholds=(0.01,), designed=("shapes-letters",),
                             episodes=1)
    rows = run_benchmark(config, tmp_path / "told", progress=False)
    assert [r["status"] for r in rows] == ["ok", "ok"]  # both told the letters cord
    letters = transition_model_file(None, cords=True, cord=designed_suite_cord("shapes-letters"))
    cells = _cells(tmp_path / "told")
    for agent in ("latent-mpc", "latent-tree-kino"):
        key = cells[f"{agent}-endpoint-shapes-letters-1cm"]["benchmark_key"]
        assert file_digest(letters) in key["model_digest"].split("+")  # kino: + its GAN's
    # Given a model of the default cord alone as the one of several cords (what told agents
    # plan on), neither can plan there: missing rows that say why.
    one_cord = replace(config, cords_transition_model=str(transition_model_file(None)))
    rows = run_benchmark(one_cord, tmp_path / "one-cord", progress=False)
    assert [r["status"] for r in rows] == ["missing", "missing"]
    assert all("trained for one cord" in r["note"] for r in rows)
