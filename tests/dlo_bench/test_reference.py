"""Reference errors of designed tasks, and the designed cells of the benchmark."""

from __future__ import annotations

import json

import numpy as np
import pytest

from dlo_bench import reference
from dlo_bench.benchmark import DEFAULT_DESIGNED, BenchmarkConfig, run_benchmark
from dlo_bench.benchmark_report import designed_panels, results_markdown, write_results
from dlo_bench.cell_store import read_cell
from dlo_bench.reference import load_references, make_references, reference_file
from dlo_env.designed_suites import designed_suite_seeds, designed_task
from dlo_env.shapes import error
from planners.physics_mpc import PhysicsMPCConfig

ENDPOINT = "dlo_env/DLOEndpoint-v0"
ONE = PhysicsMPCConfig(samples=4, elites=2, iterations=1, moves=1)
TWO = PhysicsMPCConfig(samples=4, elites=2, iterations=1, moves=1, far_moves=2, far_error=0.01)
TINY = {"searches": (ONE, TWO), "max_steps": 4}


def test_the_reference_is_a_rest_shape_no_worse_than_the_start_and_resumes(tmp_path,
                                                                           monkeypatch):
    path = make_references("shapes-curves", ENDPOINT, tmp_path, limit=2, **TINY)
    assert path == reference_file(tmp_path, "shapes-curves", ENDPOINT)
    rows = json.loads(path.read_text())["tasks"]
    seeds = [int(s) for s in designed_suite_seeds("shapes-curves", "test")[:2]]
    assert [r["seed"] for r in rows] == seeds
    for row in rows:
        task = designed_task("shapes-curves", row["seed"], "head")
        start = min(error(task.start, task.goal), error(task.start, task.goal[::-1]))
        assert len(row["searches"]) == 2  # the best of both searches
        assert row["error"] == min(r["error"] for r in row["searches"])
        assert 0 < row["error"] <= start + 1e-6 and row["family"] == task.family
        assert all(0 <= r["step"] <= r["steps"] <= 4 for r in row["searches"])

    def fail(*args, **kwargs):
        raise AssertionError("a task the file holds was searched again")

    monkeypatch.setattr(reference, "search_task", fail)
    assert make_references("shapes-curves", ENDPOINT, tmp_path, limit=2, **TINY) == path
    with pytest.raises(ValueError, match="made by another search"):
        make_references("shapes-curves", ENDPOINT, tmp_path, limit=2,
                        searches=(PhysicsMPCConfig(samples=5, elites=2, iterations=1, moves=1),),
                        max_steps=4)
    assert json.loads(path.read_text())["tasks"] == rows  # nothing lost
    assert set(load_references("shapes-curves", ENDPOINT, tmp_path)) == set(seeds)
    assert load_references("shapes-curves", ENDPOINT, tmp_path / "none") == {}


def test_bad_arguments_are_one_line_errors(tmp_path):
    with pytest.raises(ValueError, match="suite must be one of"):
        make_references("shapes-nope", ENDPOINT, tmp_path)
    with pytest.raises(ValueError, match="jobs must be"):
        make_references("shapes-curves", ENDPOINT, tmp_path, jobs=0)


@pytest.mark.parametrize("known", [2, 1])
def test_designed_cells_report_families_beside_the_reference(tmp_path, monkeypatch, known):
    make_references("shapes-curves", ENDPOINT, tmp_path / "refs", limit=known, **TINY)
    monkeypatch.setattr(reference, "SHIPPED_REFERENCES", tmp_path / "refs")
    config = BenchmarkConfig(agents=("straight-line",), envs=(ENDPOINT,), difficulties=(1,),
                             thresholds=(0.01,), designed=("shapes-curves",), episodes=2,
                             fidelity=False)
    assert config.cells()[-1] == (ENDPOINT, "shapes-curves", 0.01)
    rows = run_benchmark(config, tmp_path / "out", progress=False)
    designed = [r for r in rows if r["cell"] == "shapes-curves"]
    assert len(designed) == 1 and designed[0]["difficulty"] is None
    row = designed[0]
    path = tmp_path / "out" / "results_episodes" / "straight-line-endpoint-shapes-curves-1cm.npz"
    records = read_cell(path)["records"]
    errors = [r["rest_direction_free_error"] for r in records]
    summary = row["designed"]["all"]
    assert summary["episodes"] == 2
    assert summary["median_error"] == pytest.approx(np.median(errors))
    assert row["median_rest_error"] == pytest.approx(np.median(errors))
    refs = load_references("shapes-curves", ENDPOINT, tmp_path / "refs")
    ref_errors = [refs[s]["error"] for s in sorted(refs)]
    assert summary["reference_tasks"] == known == len(ref_errors)
    assert summary["reference_median"] == pytest.approx(np.median(ref_errors))
    assert summary["near_reference"] == np.mean(  # over the tasks with a reference
        np.array(errors[:known]) <= np.array(ref_errors) + 0.005)
    assert sum(v["episodes"] for k, v in row["designed"].items() if k != "all") == 2
    cell = read_cell(path)
    shapes = cell["shapes"]
    assert len(shapes["goals"]) == len(shapes["rest"]) == len(shapes["families"]) == 2
    assert shapes["seeds"] == [int(s) for s in designed_suite_seeds("shapes-curves", "test")[:2]]
    for goal, rest, record in zip(shapes["goals"], shapes["rest"], records):
        goal, rest = np.asarray(goal), np.asarray(rest)
        assert min(error(rest, goal), error(rest, goal[::-1])) == pytest.approx(
            record["rest_direction_free_error"], abs=1e-6)
    paths = write_results(rows, tmp_path / "out", "dlo benchmark", 1.0)
    assert paths["designed_png"].stat().st_size > 1000
    assert [label for label, _ in designed_panels(rows, tmp_path / "out")] == [
        f"endpoint {f} #{i}" for i, f in enumerate(shapes["families"])
        if f not in shapes["families"][:i] or shapes["families"][:i].count(f) < 2]
    table = results_markdown(rows, {"platform": "p", "processor": "x", "cpu_count": 2,
                                    "python": "3", "torch": "t", "torch_threads": 1},
                             "dlo benchmark", 1.0)
    label = "| reference |" if known == 2 else "| reference (1 of 2 tasks) |"
    assert "## Designed shapes" in table and label in table
    assert "| straight-line | endpoint | shapes-curves | 1 cm | 2 |" in table


@pytest.mark.parametrize(("flags", "expected"), [
    ([], list(DEFAULT_DESIGNED)),
    (["--quick"], ["shapes-curves"]),
    (["--quick", "--difficulty", "1"], []),
    (["--difficulty", "1"], []),
    (["--quick", "--designed", "shapes-curves"], ["shapes-curves"]),
    (["--designed"], []),
    (["--designed", "shapes-curves", "shapes-curves"], ["shapes-curves"]),
])
def test_which_designed_suites_a_benchmark_command_runs(flags, expected):
    from dlo_cli.benchmark import section_suites as designed_suites
    from dlo_cli.main import build_parser

    args = build_parser().parse_args(["benchmark", *flags])
    assert designed_suites(args) == expected


def test_duplicate_designed_suites_are_refused():
    with pytest.raises(ValueError, match="designed must be distinct"):
        BenchmarkConfig(designed=("shapes-curves", "shapes-curves"))


def test_a_file_of_the_first_search_alone_is_taken_up_and_completed(tmp_path, monkeypatch):
    # Files made before there were two searches hold the first one's rows: they are kept and
    # only the second search runs.
    import dataclasses

    one = make_references("shapes-curves", ENDPOINT, tmp_path, limit=2, searches=(ONE,),
                          max_steps=4)
    data = json.loads(one.read_text())
    old = {**data, "settings": {"config": dataclasses.asdict(ONE), "max_steps": 4,
                                "stop": data["settings"]["stop"]},
           "tasks": [{"seed": t["seed"], "family": t["family"], **t["searches"][0]}
                     for t in data["tasks"]]}
    one.write_text(json.dumps(old))
    assert load_references("shapes-curves", ENDPOINT, tmp_path) == {}  # one of two searches
    ran = []
    original = reference.search_task

    def counting(*args, **kwargs):
        ran.append(kwargs["config"])
        return original(*args, **kwargs)

    monkeypatch.setattr(reference, "search_task", counting)
    monkeypatch.setattr(reference, "REFERENCE_SEARCHES", (ONE, TWO))
    make_references("shapes-curves", ENDPOINT, tmp_path, limit=2, **TINY)
    assert ran == [TWO, TWO]
    rows = json.loads(one.read_text())["tasks"]
    assert [r["searches"][0]["error"] for r in rows] == [t["error"] for t in old["tasks"]]
    assert set(load_references("shapes-curves", ENDPOINT, tmp_path)) == {r["seed"] for r in rows}

