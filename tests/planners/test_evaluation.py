from __future__ import annotations

import csv
import json
import math

import gymnasium as gym
import numpy as np
import pytest

import dlo_env  # noqa: F401
from dlo_env.tasks import suite_seeds
from planners import PlannerPolicy, StraightLinePolicy, evaluate, format_table
from planners.evaluation import write_evaluation

ENV_ID = "dlo_env/DLOEndpoint-v0"


class ZeroPolicy:
    """Never moves."""

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        return np.zeros(2, dtype=np.float32), state


class ReplayPolicy:
    """Replays given action sequences, one per episode (advanced by ``reset``)."""

    def __init__(self, episodes: list[np.ndarray]) -> None:
        self.episodes = episodes
        self.index = -1

    def reset(self) -> None:
        self.index += 1
        self.step = 0

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        actions = self.episodes[self.index]
        action = actions[self.step] if self.step < len(actions) else np.zeros(2, np.float32)
        self.step += 1
        return action, state


def _reference_actions(seeds, difficulty):
    env = gym.make(ENV_ID)
    out = []
    for seed in seeds:
        _, info = env.reset(seed=seed, options={"difficulty": difficulty})
        out.append(info["reference_actions"])
    return out


def test_evaluate_records_an_idle_policy_as_failing_at_the_time_limit():
    result = evaluate(ZeroPolicy(), ENV_ID, difficulty=1, episodes=2, seed=5, fidelity=False)
    assert [r.seed for r in result.records] == [5, 6]
    for record in result.records:
        assert not record.success
        assert record.steps == 100
        assert record.difficulty == 1
        assert record.final_error == pytest.approx(record.start_error, abs=1e-3)
        assert record.plans == 0 and math.isnan(record.fidelity)
    assert result.summary["success_rate"] == 0.0
    assert result.summary["mean_steps"] == 100.0
    assert result.summary["episodes"] == 2


def test_evaluate_records_a_scripted_replay_of_the_reference_moves_as_solved():
    references = _reference_actions([0, 1, 2], difficulty=2)
    result = evaluate(ReplayPolicy(references), ENV_ID, difficulty=2, episodes=3, seed=0)
    for record, reference in zip(result.records, references):
        assert record.success
        assert record.final_error <= 0.02
        assert record.steps <= len(reference)  # the environment terminates on success
        assert record.start_error > 0.02
    assert result.summary["success_rate"] == 1.0
    errors = [r.final_error for r in result.records]
    assert result.summary["median_final_error"] == pytest.approx(float(np.median(errors)))
    assert result.summary["mean_final_error"] == pytest.approx(float(np.mean(errors)))


def test_evaluate_runs_the_fixed_tasks_of_a_suite():
    result = evaluate(StraightLinePolicy(), ENV_ID, suite="linear-1", episodes=2)
    assert [r.task_seed for r in result.records] == list(suite_seeds("linear-1", "test")[:2])
    assert all(r.difficulty == 1 and r.seed == -1 for r in result.records)


def test_evaluate_reports_plans_and_fidelity_of_planner_policies(toy_model):
    result = evaluate(PlannerPolicy(toy_model), ENV_ID, difficulty=1, episodes=1, seed=0)
    record = result.records[0]
    assert record.plans == 1
    assert record.fidelity > 0 and math.isfinite(record.fidelity)
    assert record.planning_seconds > 0
    assert result.summary["mean_fidelity"] == pytest.approx(record.fidelity)


def test_evaluation_is_written_as_csv_and_json(tmp_path):
    result = evaluate(ZeroPolicy(), ENV_ID, difficulty=1, episodes=2, seed=0, fidelity=False,
                      agent="zero")
    csv_path, json_path = write_evaluation(result, tmp_path, "zero-d1", extra={"note": "x"})
    with open(csv_path, newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 2 and rows[0]["success"] == "False" and rows[0]["fidelity"] == ""
    data = json.loads(json_path.read_text())
    assert data["summary"]["agent"] == "zero" and data["note"] == "x"
    assert data["records"][1]["steps"] == 100
    assert data["summary"]["mean_fidelity"] is None  # NaN is written as null
    assert "zero" in format_table([result.summary])


def test_evaluate_rejects_bad_arguments():
    with pytest.raises(ValueError, match="policy must have a predict"):
        evaluate(object(), ENV_ID)
    with pytest.raises(ValueError, match="episodes must be an int >= 1"):
        evaluate(ZeroPolicy(), ENV_ID, episodes=0)
    with pytest.raises(ValueError, match="difficulty or suite, not both"):
        evaluate(ZeroPolicy(), ENV_ID, difficulty=1, suite="linear-1")


@pytest.mark.slow
def test_evaluate_drives_a_stable_baselines3_model():
    from stable_baselines3 import PPO

    model = PPO("MultiInputPolicy", gym.make(ENV_ID), n_steps=64, batch_size=32, seed=0,
                device="cpu")
    result = evaluate(model, ENV_ID, difficulty=1, episodes=1, seed=0)
    record = result.records[0]
    assert 1 <= record.steps <= 100
    assert record.plans == 0 and math.isnan(record.fidelity)
