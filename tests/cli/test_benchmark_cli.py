"""``dlo benchmark``: every agent, one table, missing agents reported."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from dlo_bench.cell_store import read_cell
from dlo_bench.paths import shipped_baseline
from dlo_bench.report import threshold_label
from dlo_cli.main import main

AGENTS = ["straight-line", "latent-tree", "latent-tree-closed", "latent-tree-kino", "physics-mpc",
          "latent-mpc", "grad-mpc", "latent-mpc-distilled", "ppo",
          "sac-her", "ppo-surrogate", "sac-her-surrogate", "bc"]
ROW_KEYS = {"agent", "difficulty", "success_rate", "median_error", "seconds_per_episode",
            "training_env_steps", "status"}


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    """Tiny PPO and SAC + HER baselines, an untrained shape model and the shipped behaviour
    cloning model: plumbing, not quality."""
    from dlo_bench.baselines import BaselineConfig, train_baseline
    from latent_model import ShapeModel
    from latent_model.config import ModelConfig
    from latent_model.normalisation import Normalisation

    root = tmp_path_factory.mktemp("bench-models")
    tiny = dict(timesteps=256, n_envs=1, net_arch=(16, 16), ppo_n_steps=128, ppo_batch_size=64,
                ppo_epochs=1, sac_buffer_size=1000, sac_batch_size=32, sac_learning_starts=150,
                checkpoint_every=0)
    for algo in ("ppo", "sac-her"):
        train_baseline(BaselineConfig(algo=algo, **tiny), root / algo, progress_bar=False)
    ShapeModel(ModelConfig(), Normalisation(), device="cpu").save(root / "shape.pt")
    shutil.copytree(shipped_baseline("bc"), root / "bc")  # trained offline: no extra needed
    for trained_in_surrogate in ("ppo-surrogate", "sac-her-surrogate"):
        shutil.copytree(shipped_baseline(trained_in_surrogate), root / trained_in_surrogate)
    shutil.copytree(shipped_baseline("latent-mpc-distilled"), root / "latent-mpc-distilled")
    return root


@pytest.mark.slow
def test_quick_benchmark_writes_every_agent_and_difficulty(models, tmp_path, capsys):
    out = tmp_path / "bench"
    # Difficulty 1 only: the physics planner is the slow agent (the other suites run the same
    # code, and the missing-agent test covers all three).
    code = main(["benchmark", "--quick", "--episodes", "1", "--difficulty", "1",
                 "--threshold", "0.02", "--env", "dlo_env/DLOEndpoint-v0",
                 "--baselines", str(models),
                 "--model", str(models / "shape.pt"), "--max-seconds", "0.05",
                 "--replan-every", "50", "--allow-dirty", "--out", str(out)])
    assert code == 0
    printed = capsys.readouterr().out
    run = printed.splitlines()[0].split()[2].rstrip(":")  # "benchmark run RUN: ..."
    for fast in ("latent-tree", "latent-mpc"):  # all cells of one invocation: comparable
        assert f"Planning time physics-mpc / {fast} on the same episodes, timed in one run " \
               f"({run}): " in printed
    rows = json.loads((out / "results.json").read_text())
    assert [r["agent"] for r in rows] == AGENTS and {r["difficulty"] for r in rows} == {1}
    assert {r["threshold"] for r in rows} == {0.02}
    for row in rows:
        assert ROW_KEYS <= set(row) and row["status"] == "ok" and row["episodes"] == 1
        assert 0.0 <= row["success_rate"] <= 1.0 and row["median_error"] > 0
        assert row["median_rest_error"] > 0
        assert row["seconds_per_episode"] > 0
    assert {r["run"] for r in rows} == {run}
    assert {r["training_env_steps"] for r in rows if r["agent"] in ("ppo", "sac-her")} == {256}
    costs = {r["agent"]: r["sample_cost"] for r in rows}
    assert costs["sac-her"] == "256 env steps"
    assert "env steps" in costs["latent-mpc"] and "simulated shapes" in costs["latent-tree"]
    assert costs["physics-mpc"].startswith("none")
    assert costs["latent-mpc-distilled"].startswith("0 env steps + ")  # all in the surrogate
    table = (out / "results.md").read_text()
    assert "| physics-mpc | endpoint | linear-1 | 2 cm | 1 |" in table and "Machine:" in table
    assert "## Success at 2 cm\n\n| agent | endpoint d1 | sample cost |" in table
    assert "Command: `dlo benchmark --quick --episodes 1" in table
    assert (out / "results.png").stat().st_size > 0
    assert (out / "results_episodes" / "sac-her-endpoint-d1-2cm.npz").is_file()


def test_agents_without_a_model_are_reported_not_dropped(tmp_path, capsys):
    out = tmp_path / "bench"
    code = main(["benchmark", "--quick", "--agent", "straight-line", "ppo", "sac-her",
                 "latent-tree", "bc", "--difficulty", "1", "2", "--episodes", "1",
                 "--threshold", "0.02", "0.01",
                 "--baselines", str(tmp_path / "none"), "--allow-dirty", "--out", str(out)])
    assert code == 0
    rows = json.loads((out / "results.json").read_text())
    assert [(r["agent"], r["threshold"], r["env"], r["difficulty"]) for r in rows] == [
        (a, t, e, d) for a in ("straight-line", "ppo", "sac-her", "latent-tree", "bc")
        for t in (0.02, 0.01) for e in ("endpoint", "dual-endpoint") for d in (1, 2)]
    for r in rows:
        if r["agent"] in ("straight-line", "latent-tree"):  # both act in both environments
            assert r["status"] == "ok"
            continue
        assert r["status"] == "missing" and r["success_rate"] is None
        assert r["note"].startswith(f"no trained model for {r['env_id']}")
    table = (out / "results.md").read_text()
    assert "| ppo | dual-endpoint | linear-2 | 1 cm | – | missing |" in table
    assert table.index("## Success at 1 cm") < table.index("## Success at 2 cm")
    assert "| ppo | – | – | – | – |" in table  # the success table
    assert "with missing cells (reported in the table): bc, ppo, sac-her" in \
        capsys.readouterr().out


def test_resume_reuses_finished_cells(tmp_path, capsys):
    args = ["benchmark", "--agent", "straight-line", "--difficulty", "1", "--episodes", "1",
            "--env", "dlo_env/DLOEndpoint-v0", "--allow-dirty", "--out", str(tmp_path)]
    assert main(args) == 0
    first = json.loads((tmp_path / "results.json").read_text())
    capsys.readouterr()
    assert main([*args, "--resume"]) == 0
    assert "straight-line-endpoint-d1-0.5cm: reused" in capsys.readouterr().out
    assert json.loads((tmp_path / "results.json").read_text())[0]["median_error"] == \
        first[0]["median_error"]


def test_benchmark_rejects_an_unknown_agent(tmp_path, capsys):
    assert main(["benchmark", "--agent", "teleport", "--out", str(tmp_path)]) == 2
    assert "argument --agent: agent name must be one of" in capsys.readouterr().err


def test_quick_runs_the_headline_threshold_only(tmp_path):
    out = tmp_path / "bench"
    assert main(["benchmark", "--quick", "--agent", "straight-line", "--difficulty", "1",
                 "--env", "dlo_env/DLOEndpoint-v0", "--allow-dirty", "--out", str(out)]) == 0
    rows = json.loads((out / "results.json").read_text())
    assert [r["threshold"] for r in rows] == [0.01]
    assert "--threshold" not in (out / "results.md").read_text()


def test_the_cords_section_runs_its_agents_on_held_out_cords(tmp_path, capsys):
    """--cords runs the cord suites with the agents of the cords section among --agent; the
    agents of that section alone never run the linear cells; rows break success down by
    cord."""
    out = tmp_path / "bench"
    empty = tmp_path / "no-model"  # a folder without transition.pt: the agent is missing
    empty.mkdir()
    assert main(["benchmark", "--agent", "straight-line", "latent-tree", "latent-mpc-adaptive",
                 "--difficulty", "1", "--threshold", "0.02", "--cords", "cords-1",
                 "--designed", "--episodes", "7", "--env", "dlo_env/DLOEndpoint-v0",
                 "--cords-transition-model", str(empty), "--allow-dirty",
                 "--out", str(out)]) == 0
    rows = json.loads((out / "results.json").read_text())
    assert [(r["agent"], r["suite"], r["status"]) for r in rows] == [
        ("straight-line", "linear-1/test", "ok"), ("straight-line", "cords-1/test", "ok"),
        ("latent-tree", "linear-1/test", "ok"),
        ("latent-mpc-adaptive", "cords-1/test", "missing")]
    cords = rows[1]["cords"]
    assert sorted(cords) == [str(i) for i in range(6)]
    assert [c["episodes"] for c in cords.values()] == [2, 1, 1, 1, 1, 1]
    assert rows[3]["note"].startswith("no transition model")
    assert "--cord-inputs" in rows[3]["note"]
    table = (out / "results.md").read_text()
    assert "## Unknown cords" in table and "**cords-1, endpoint, 2 cm**" in table
    only = tmp_path / "cords-only"
    assert main(["benchmark", "--agent", "straight-line", "--difficulty", "--designed",
                 "--cords", "cords-1", "--threshold", "0.02", "--episodes", "1",
                 "--allow-dirty", "--out", str(only)]) == 0
    alone = (only / "results.md").read_text()
    assert "## Success" not in alone and "## Unknown cords" in alone  # no empty table
    assert "| cords-1" not in table.split("## Every cell")[0].split("## Unknown")[0]
    printed = capsys.readouterr().out
    assert "| straight-line |" in printed.split("cords-1, endpoint")[1]


def test_a_config_made_in_code_runs_no_cords_section_unless_asked():
    from dlo_bench.benchmark import CORD_AGENTS, BenchmarkConfig

    config = BenchmarkConfig(agents=("straight-line",), designed=())
    assert config.all_agents == ("straight-line",)
    assert all(suite.startswith("linear-") for _, suite, _ in config.cells())
    asked = BenchmarkConfig(agents=("straight-line",), designed=(), cords=("cords-3",))
    assert asked.all_agents == ("straight-line", *CORD_AGENTS[1:])
    assert asked.cells("physics-mpc-true-cord") == [
        ("dlo_env/DLOEndpoint-v0", "cords-3", 0.01)]


def test_agents_of_the_cords_section_alone_need_a_cord_suite(tmp_path, capsys):
    assert main(["benchmark", "--agent", "physics-mpc-true-cord", "--quick", "--cords",
                 "--allow-dirty", "--out", str(tmp_path)]) == 2
    assert "add --cords SUITE" in capsys.readouterr().err


def test_a_fine_tuned_model_counts_the_data_of_the_model_it_started_from():
    from dlo_bench.loaded_agent import training_data

    base = {"env_steps": 1000, "data_transitions": 100,
            "sources": [{"digest": "a", "transitions": 60}, {"digest": "b", "transitions": 40}]}
    assert training_data(base) == (1000, 100)  # no init: as recorded
    tuned = {"env_steps": 500, "data_transitions": 50, "init_model": {"info": base},
             "sources": [{"digest": "b", "transitions": 40}, {"digest": "c", "transitions": 10}]}
    # b once: the tuned level's 500 steps for its 50 moves, then a (600 of base's 1000)
    assert training_data(tuned) == (1100, 110)
    distilled = {"env_steps": 500, "data_transitions": 50, "ensemble": tuned,
                 "sources": tuned["sources"]}  # a mean network distilled on the same files
    assert training_data(distilled) == (1100, 110)
    assert training_data({**base, "ensemble": base}) == (1000, 100)  # no new file: as recorded
    # moves are the recorded ones (after what training left out), shared out by file size
    trimmed = {**tuned, "data_transitions": 45}
    assert training_data(trimmed) == (1100, 105)
    # a model without files of its own is never counted below what it records
    assert training_data({"env_steps": 100, "data_transitions": 10, "init_model": {
        "info": {"env_steps": 50, "data_transitions": 5, "sources": [
            {"digest": "a", "transitions": 5}]}}}) == (100, 10)
    assert training_data({}) == (None, None)


def test_the_pegs_section_runs_among_pegs_with_the_rl_agents_trained_there(tmp_path, capsys):
    """--pegs runs the suites with pegs in an environment that observes them: an RL agent reads
    its ALGO-pegs folder, behaviour cloning (no demonstrations with pegs) is n/a, not missing;
    the section has its own table, outside the main ones."""
    from dlo_bench.baselines import BaselineConfig, train_baseline

    baselines = tmp_path / "baselines"
    train_baseline(BaselineConfig(algo="sac-her", timesteps=256, n_envs=1, net_arch=(16, 16),
                                  sac_buffer_size=1000, sac_batch_size=32,
                                  sac_learning_starts=150, checkpoint_every=0, max_pegs=4),
                   baselines / "sac-her-pegs", progress_bar=False)
    out = tmp_path / "bench"
    assert main(["benchmark", "--agent", "straight-line", "sac-her", "bc", "--difficulty",
                 "--designed", "--cords", "--pegs", "route-2", "--threshold", "0.02",
                 "--episodes", "1", "--baselines", str(baselines), "--allow-dirty",
                 "--out", str(out)]) == 0
    rows = json.loads((out / "results.json").read_text())
    assert [(r["agent"], r["env"], r["suite"], r["status"]) for r in rows] == [
        ("straight-line", "endpoint", "route-2/test", "ok"),
        ("straight-line", "dual-endpoint", "route-2/test", "ok"),
        ("sac-her", "endpoint", "route-2/test", "ok"),
        ("sac-her", "dual-endpoint", "route-2/test", "missing"),
        ("bc", "endpoint", "route-2/test", "n/a"),
        ("bc", "dual-endpoint", "route-2/test", "n/a")]
    assert rows[2]["models"] == [str(baselines / "sac-her-pegs" / "model.zip")]
    # the dual environment's RL agent is its own folder, named with the command that makes it
    assert "sac-her-pegs-dual-endpoint" in rows[3]["note"]
    assert "--max-pegs 4" in rows[3]["note"]
    assert "no pegs" in rows[4]["note"]
    table = (out / "results.md").read_text()
    assert "## Success" not in table and "## Pegs" in table
    assert "| bc | n/a |" in table.split("## Pegs")[1]
    assert "Cells where an agent cannot act (n/a):" in table
    cell = read_cell(out / "results_episodes" / "straight-line-endpoint-route-2-2cm.npz")
    from dlo_env.peg_suites import load_route_suite

    task = load_route_suite("route-2", limit=1)[0]
    assert cell["shapes"]["pegs"] == [task.pegs.tolist()]  # the figure draws the task's pegs
    assert cell["shapes"]["goals"] == [task.goal.tolist()]
    assert (out / "results_pegs.png").stat().st_size > 0 and not (out / "results.png").exists()
    printed = capsys.readouterr().out
    endpoint = printed.split("**endpoint, 2 cm**")[1].split("**dual-endpoint")[0]
    sac_her = [line for line in endpoint.splitlines() if line.startswith("| sac-her | ")]
    assert len(sac_her) == 1 and "%" in sac_her[0]  # a result, not the missing cell's dash
    assert main(["benchmark", "--agent", "straight-line", "sac-her", "--difficulty",
                 "--designed", "--cords", "--pegs", "route-2", "--threshold", "0.02",
                 "--episodes", "1", "--baselines", str(baselines), "--allow-dirty",
                 "--resume", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "straight-line-endpoint-route-2-2cm: reused" in printed
    assert "sac-her-endpoint-route-2-2cm: reused" in printed


def test_the_pegs_section_has_its_own_transition_model_and_rl_folders(tmp_path):
    """Where pegs are observed the model-based agents plan with --pegs-transition-model and
    the RL agents read ALGO-pegs folders; elsewhere neither changes."""
    import gymnasium as gym

    from dlo_bench.benchmark import PEG_AGENTS, BenchmarkConfig, load_agent

    config = BenchmarkConfig(agents=("straight-line",), designed=())
    assert not any(suite.startswith(("pegs-", "route-")) for _, suite, _ in config.cells())
    asked = BenchmarkConfig(agents=("straight-line",), designed=(), pegs=("pegs-1",),
                            pegs_transition_model=str(tmp_path / "none.pt"),
                            baselines=str(tmp_path))
    assert asked.all_agents == ("straight-line", *(a for a in PEG_AGENTS if a != "straight-line"))
    assert asked.cells("bc") == [("dlo_env/DLOEndpoint-v0", "pegs-1", 0.01),
                                 ("dlo_env/DLODualEndpoint-v0", "pegs-1", 0.01)]
    with gym.make("dlo_env/DLOEndpoint-v0") as plain, \
            gym.make("dlo_env/DLOEndpoint-v0", max_pegs=4) as pegged:
        assert load_agent("latent-mpc", asked, plain).policy is not None  # the shipped model
        assert load_agent("latent-mpc", asked, pegged).missing.startswith("no transition model")
        ppo = load_agent("ppo", asked, pegged)
        assert ppo.policy is None and ppo.applicable and "ppo-pegs/" in ppo.missing
        assert "--max-pegs 4" in ppo.missing
        from dlo_bench.agents import build_agent

        with pytest.raises(ValueError, match="'bc' does not act where pegs are observed"):
            build_agent("bc", pegged)
    with pytest.raises(ValueError, match="peg_agents must be"):
        BenchmarkConfig(pegs=("pegs-1",), peg_agents=("latent-mpc-adaptive",))
    with pytest.raises(ValueError, match="pegs must be distinct suites"):
        BenchmarkConfig(pegs=("linear-1",))


@pytest.mark.parametrize(("flags", "expected"), [
    ([], ["pegs-1", "pegs-2", "pegs-3", "route-2", "route-3", "route-4"]),
    (["--quick"], ["pegs-1"]),
    (["--quick", "--difficulty", "1"], []),
    (["--difficulty", "1"], []),
    (["--difficulty"], []),
    (["--pegs"], []),
    (["--quick", "--pegs", "route-3", "route-3"], ["route-3"]),
])
def test_which_peg_suites_a_benchmark_command_runs(flags, expected):
    from dlo_cli.benchmark import section_suites
    from dlo_cli.main import build_parser

    args = build_parser().parse_args(["benchmark", *flags])
    assert section_suites(args, "pegs") == expected


def test_committed_cells_keep_their_keys():
    """A field added to BenchmarkConfig must not change the key of the committed cells (every
    one would be run again by --resume): the key recomputed today matches the file's."""
    import gymnasium as gym

    from dlo_bench.benchmark import (
        DEFAULT_CORDS,
        DEFAULT_PEGS,
        BenchmarkConfig,
        cell_key,
        load_agent,
    )
    from dlo_bench.report import json_ready

    folder = Path(__file__).resolve().parents[2] / "benchmarks" / "results_episodes"
    config = BenchmarkConfig(cords=DEFAULT_CORDS, pegs=DEFAULT_PEGS)
    for name, suite, threshold in (("straight-line", "linear-3", 0.01),
                                   ("latent-mpc", "linear-3", 0.01),
                                   ("physics-mpc", "linear-1", 0.02)):
        path = folder / f"{name}-endpoint-d{suite[-1]}-{threshold_label(threshold, '')}.npz"
        with gym.make("dlo_env/DLOEndpoint-v0") as env:
            agent = load_agent(name, config, env)
        key = cell_key(config, agent, "dlo_env/DLOEndpoint-v0", suite, threshold)
        assert read_cell(path)["benchmark_key"] == json_ready(key), path.name


def test_an_sb3_agent_runs_where_its_spaces_fit_and_is_n_a_elsewhere(tmp_path):
    pytest.importorskip("stable_baselines3")
    import gymnasium as gym
    from stable_baselines3 import PPO

    model = tmp_path / "mine.zip"
    PPO("MultiInputPolicy", gym.make("dlo_env/DLOEndpoint-v0"), n_steps=32,
        batch_size=32).save(model)
    out = tmp_path / "bench"
    code = main(["benchmark", "--quick", "--agent", f"sb3:{model}",
                 f"sb3:{shipped_baseline('ppo')}", "--difficulty", "1", "--episodes", "1",
                 "--allow-dirty", "--out", str(out)])
    assert code == 0
    rows = {(r["agent"], r["env"]): r for r in json.loads((out / "results.json").read_text())}
    mine = rows[(f"sb3:{model}", "endpoint")]
    assert mine["status"] == "ok" and mine["training_env_steps"] is None
    assert rows[(f"sb3:{model}", "dual-endpoint")]["status"] == "n/a"
    shipped = rows[(f"sb3:{shipped_baseline('ppo')}", "endpoint")]
    assert shipped["status"] == "ok" and shipped["training_env_steps"] > 0
    assert "sb3--" in " ".join(p.name for p in (out / "results_episodes").iterdir())


@pytest.mark.parametrize("flag", ["--cords-transition-model", "--pegs-transition-model"])
def test_a_missing_section_transition_model_is_refused_before_the_run(flag, tmp_path, capsys):
    code = main(["benchmark", "--agent", "straight-line", flag, str(tmp_path / "nope.pt"),
                 "--allow-dirty", "--out", str(tmp_path / "bench")])
    assert code == 2
    assert f"argument {flag}: no transition model file or folder at" in capsys.readouterr().err
    assert not (tmp_path / "bench").exists()


def test_the_command_prints_the_sections_tables_and_none_of_their_prose(tmp_path, capsys,
                                                                          monkeypatch):
    import dlo_bench.benchmark_report as report

    prose = ["## Pegs", "", "First line of prose.", "Second line of prose.",
             "Third line of prose.", "",
             "**endpoint, 1 cm**", "", "| agent | pegs-1 |", "|---|---|", "| x | 1% |", ""]
    monkeypatch.setattr(report, "pegs_section", lambda rows: prose)
    assert main(["benchmark", "--agent", "straight-line", "--difficulty", "1", "--env",
                 "dlo_env/DLOEndpoint-v0", "--episodes", "1", "--threshold", "0.02",
                 "--allow-dirty", "--out", str(tmp_path / "bench")]) == 0
    printed = capsys.readouterr().out
    assert "**endpoint, 1 cm**\n| agent | pegs-1 |\n|---|---|\n| x | 1% |" in printed
    assert "prose" not in printed
