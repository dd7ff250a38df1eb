"""Specification: the benchmark and ``dlo evaluate`` on Ray give the results of the local run.

A cell (agent, environment, difficulty) is built and evaluated from scratch wherever it runs,
so the order and the process do not matter. (A task whose worker dies is run again by
``RayBackend.map``; tests/dlo_env/test_ray_backend.py kills one.)
"""

from __future__ import annotations

import pytest

from dlo_bench.benchmark import BenchmarkConfig, run_benchmark
from dlo_bench.cell_store import read_cell
from dlo_cli.main import main
from dlo_env.core.ray_backend import RayBackend

ray = pytest.importorskip("ray", reason='needs the ray extra: pip install -e ".[ray]"')

#: What must be equal between backends (times are not).
SAME = ("agent", "env", "difficulty", "status", "episodes", "success_rate", "median_error",
        "mean_error", "mean_steps")


@pytest.fixture(scope="module")
def local_ray():
    """A local Ray runtime with 2 CPUs, started by the test and shut down after it."""
    ray.init(num_cpus=2, include_dashboard=False, logging_level="warning")
    yield
    ray.shutdown()


@pytest.mark.slow
def test_benchmark_cells_on_ray_equal_the_local_ones(local_ray, tmp_path):
    config = BenchmarkConfig(agents=("straight-line", "physics-mpc", "latent-mpc",
                                     "latent-tree-kino"),
                             envs=("dlo_env/DLOEndpoint-v0", "dlo_env/DLODualEndpoint-v0"),
                             difficulties=(2,), thresholds=(0.02,), designed=(), episodes=1,
                             fidelity=False,
                             max_seconds=60.0)  # kino's search ends by goal or nodes, not time
    local = run_benchmark(config, tmp_path / "local", progress=False)
    on_ray = run_benchmark(config, tmp_path / "ray", progress=False, backend=RayBackend())
    assert [{k: r[k] for k in SAME} for r in on_ray] == [{k: r[k] for k in SAME} for r in local]
    assert [r["status"] for r in local].count("missing") == 0  # every agent acts in both
    for r in (r for r in local if r["status"] == "ok"):
        cell = f"{r['agent']}-{r['env']}-d2-2cm.npz"
        records = [read_cell(tmp_path / d / "results_episodes" / cell)["records"]
                   for d in ("local", "ray")]
        assert [x["final_error"] for x in records[0]] == [x["final_error"] for x in records[1]]


@pytest.mark.slow
def test_evaluate_on_ray_writes_the_local_rows(local_ray, tmp_path, capsys):
    args = ["evaluate", "--agent", "straight-line", "latent-mpc", "--suite", "linear-2",
            "--episodes", "2", "--no-fidelity"]
    assert main([*args, "--out", str(tmp_path / "local")]) == 0
    assert main([*args, "--backend", "ray", "--out", str(tmp_path / "ray")]) == 0
    assert "latent-mpc linear-2: success" in capsys.readouterr().out
    for name in ("straight-line-linear-2.csv", "latent-mpc-linear-2.csv"):
        local = (tmp_path / "local" / name).read_text().splitlines()
        remote = (tmp_path / "ray" / name).read_text().splitlines()
        column = local[0].split(",").index("final_error")
        assert [row.split(",")[column] for row in remote] == \
            [row.split(",")[column] for row in local]
