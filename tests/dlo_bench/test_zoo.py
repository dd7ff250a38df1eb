"""Specification: rl-zoo3 trains the project's baselines from the shipped hyperparameter files,
through its own entry points, and its enjoy script loads the result."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from dlo_bench.baselines import BaselineConfig
from dlo_bench.zoo import ZOO_ENVS, hyperparameters_file, zoo_file_contents, zoo_hyperparameters

PRETRAINED = Path(__file__).parents[2] / "dlo_bench" / "pretrained"
ZOO_REASON = 'needs the zoo extra (rl-zoo3): pip install -e ".[zoo]"'


def test_zoo_hyperparameters_are_the_settings_of_the_shipped_baselines():
    for zoo_algo, folder in (("ppo", "ppo"), ("sac", "sac-her")):
        shipped = json.loads((PRETRAINED / folder / "hyperparameters.json").read_text())
        config = BaselineConfig.from_dict(shipped["config"])
        assert zoo_file_contents(zoo_algo)[config.env_id] == zoo_hyperparameters(config)


def test_sac_file_trains_sac_with_her_and_the_training_difficulties():
    entry = zoo_file_contents("sac")[ZOO_ENVS[1]]
    assert entry["replay_buffer_class"] == "HerReplayBuffer"
    assert entry["env_wrapper"] == [
        {"dlo_bench.baselines.RandomDifficulty": {"difficulties": [1, 2, 3]}}]


def test_unknown_zoo_algo_is_refused_naming_the_argument():
    with pytest.raises(ValueError, match="zoo_algo must be one of"):
        hyperparameters_file("td3")


@pytest.mark.parametrize("zoo_algo", ["ppo", "sac"])
def test_shipped_yaml_files_hold_what_the_baseline_config_gives(zoo_algo):
    yaml = pytest.importorskip("yaml", reason=ZOO_REASON)
    shipped = yaml.safe_load(hyperparameters_file(zoo_algo).read_text())
    assert shipped == zoo_file_contents(zoo_algo)


def run_zoo(script: str, args: list[str], cwd: Path) -> str:
    """``python -m rl_zoo3.SCRIPT ARGS`` in ``cwd``; its stdout (stderr shown on failure).
    SB3's logger writes into ``cwd`` (``SB3_LOGDIR``), not an ``SB3-<time>`` folder in the
    temp dir."""
    env = {**os.environ, "SB3_LOGDIR": str(cwd / "sb3-log")}
    result = subprocess.run([sys.executable, "-m", f"rl_zoo3.{script}", *args], cwd=cwd,
                            capture_output=True, text=True, timeout=540, env=env)
    assert result.returncode == 0, (result.stdout[-2000:], result.stderr[-3000:])
    return result.stdout


@pytest.mark.slow
@pytest.mark.parametrize(("zoo_algo", "env_id", "steps", "overrides"), [
    # PPO in SubprocVecEnv workers: the plain id works there through --gym-packages.
    ("ppo", ZOO_ENVS[0], 256, ["n_steps:64", "batch_size:64", "n_epochs:1", "--vec-env",
                               "subproc"]),
    # SAC + HER: learning starts once both environments finished an episode (100 steps).
    ("sac", ZOO_ENVS[1], 240, ["learning_starts:210"]),
])
def test_rl_zoo3_trains_from_the_shipped_file_and_enjoy_loads_the_model(
        zoo_algo, env_id, steps, overrides, tmp_path):
    pytest.importorskip("rl_zoo3", reason=ZOO_REASON)
    common = ["--algo", zoo_algo, "--env", env_id, "--gym-packages", "dlo_env",
              "-f", "logs", "--num-threads", "1"]
    out = run_zoo("train", [*common, "-conf", str(hyperparameters_file(zoo_algo)),
                            "-n", str(steps), "--eval-freq", "-1", "--seed", "0",
                            "-params", *overrides], tmp_path)
    name = env_id.replace("/", "-")
    run = tmp_path / "logs" / zoo_algo / f"{name}_1"
    assert (run / f"{name}.zip").is_file() and "Saving to" in out
    episodes = (run / "0.monitor.csv").read_text().splitlines()[2:]  # after the two headers
    assert len(episodes) >= 1 and episodes[0].split(",")[1] == "100"  # a full-length episode
    config = (run / name / "config.yml").read_text()
    assert "RandomDifficulty" in config
    enjoyed = run_zoo("enjoy", [*common, "--exp-id", "1", "-n", "100", "--no-render",
                                "--deterministic"], tmp_path)
    assert "Episode Length 100" in enjoyed or "Success?" in enjoyed
