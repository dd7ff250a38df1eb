from __future__ import annotations

import csv
import json
import math

import gymnasium as gym
import numpy as np
import pytest

import dlo_env  # noqa: F401
from dlo_bench import (
    FidelityProfile,
    divergence,
    evaluate,
    format_divergence,
    format_table,
    write_evaluation,
)
from dlo_env.tasks import suite_seeds
from planners import PlannerPolicy, StraightLinePolicy

ENV_ID = "dlo_env/DLOEndpoint-v0"


class ZeroPolicy:
    """Never moves."""

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        return np.zeros(2, dtype=np.float32), state


class ReplayPolicy:
    """Replays given action sequences, one per episode (advanced at every ``episode_start``)."""

    def __init__(self, episodes: list[np.ndarray]) -> None:
        self.episodes = episodes
        self.index = -1

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        if episode_start is not None and bool(episode_start[0]):
            self.index += 1
            self.step = 0
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


def test_long_horizons_get_their_episode_length_and_the_rest_error_is_recorded():
    # linear-8 episodes last 160 steps; random tasks of difficulty 9, 180.
    suite = evaluate(ZeroPolicy(), ENV_ID, suite="linear-8", episodes=1, fidelity=False)
    random = evaluate(ZeroPolicy(), ENV_ID, difficulty=9, episodes=1, fidelity=False)
    assert suite.records[0].steps == 160 and random.records[0].steps == 180
    for record in (*suite.records, *random.records):
        # The idle cord is at rest where it started: its rest errors are its errors.
        assert record.rest_error == pytest.approx(record.final_error, abs=1e-6)
        assert record.rest_max_error == pytest.approx(record.final_max_error, abs=1e-6)
        assert record.rest_max_error > record.rest_error
    assert suite.summary["median_rest_max_error"] == suite.records[0].rest_max_error
    # A given environment keeps its own limit.
    given = evaluate(ZeroPolicy(), gym.make(ENV_ID), suite="linear-8", episodes=1,
                     fidelity=False)
    assert given.records[0].steps == 100


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


def test_an_unknown_suite_is_refused_naming_the_suites_of_every_kind():
    with pytest.raises(ValueError) as info:
        evaluate(StraightLinePolicy(), ENV_ID, suite="linear-99", episodes=1)
    for name in ("linear-1", "shapes-curves", "cords-3", "pegs-2", "route-4", "'linear-99'"):
        assert name in str(info.value)


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


def test_divergence_pools_planned_shapes_by_end_travel_and_by_move():
    profiles = [
        FidelityProfile(0, errors=np.array([0.001, 0.01, 0.03]), travel=np.array([0.0, 0.06, 0.12]),
                        move=np.array([0, 0, 1])),
        FidelityProfile(1, errors=np.array([0.003, 0.02]), travel=np.array([0.0, 0.04]),
                        move=np.array([0, 0])),
    ]
    d = divergence(profiles)
    assert d["plans"] == 2 and d["shapes"] == 5
    assert d["at_start"] == pytest.approx(0.002) and d["at_end"] == pytest.approx(0.025)
    assert d["by_travel"]["0-5 cm"] == pytest.approx((0.001 + 0.003 + 0.02) / 3)
    assert d["by_travel"]["5-10 cm"] == pytest.approx(0.01)
    assert d["by_travel"]["10-20 cm"] == pytest.approx(0.03)
    assert math.isnan(d["by_travel"][">=30 cm"])
    assert d["by_move"]["1"] == pytest.approx((0.001 + 0.01 + 0.003 + 0.02) / 4)
    assert d["by_move"]["2"] == pytest.approx(0.03) and math.isnan(d["by_move"]["3+"])


def test_evaluate_records_the_first_plan_and_where_it_parts_ways_with_the_cord(toy_model,
                                                                               tmp_path):
    result = evaluate(PlannerPolicy(toy_model), ENV_ID, difficulty=1, episodes=2, seed=0,
                      agent="toy")
    assert len(result.profiles) == 2
    for record, profile in zip(result.records, result.profiles):
        assert record.plan_moves >= 1 and record.plan_travel > 0
        assert record.fidelity == pytest.approx(profile.errors.mean())
        assert record.fidelity_max == pytest.approx(profile.errors.max())
        assert record.start_inversion_error == pytest.approx(profile.errors[0], abs=1e-6)
        assert math.isfinite(record.goal_inversion_error)
    assert result.summary["divergence"]["plans"] == 2
    table = format_divergence([result.summary])
    assert "toy" in table and "travel 0-5 cm" in table
    _, json_path = write_evaluation(result, tmp_path, "toy-d1")
    data = json.loads(json_path.read_text())
    assert len(data["fidelity_profiles"]) == 2


class CountingPlanner:
    """A planning policy that never moves and reports made-up statistics through the protocol."""

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        return np.zeros(2, dtype=np.float32), state

    def reset(self) -> None:
        pass

    def check_env(self, env) -> None:
        pass

    def episode_stats(self):
        from planners import EpisodeStats

        return EpisodeStats(plans=3, failures=1, seconds=0.25, goal_inversion_error=0.004)


def test_evaluate_records_what_a_planning_policy_reports_through_episode_stats():
    result = evaluate(CountingPlanner(), ENV_ID, difficulty=1, episodes=1, seed=0)
    record = result.records[0]
    assert (record.plans, record.planning_failures) == (3, 1)
    assert record.planning_seconds == 0.25 and record.goal_inversion_error == 0.004
    assert math.isnan(record.fidelity)  # no first plan reported: nothing to simulate


def test_evaluate_takes_an_environment_as_build_agent_does_and_leaves_it_open(monkeypatch):
    env = gym.make(ENV_ID)
    closed: list[bool] = []
    monkeypatch.setattr(env, "close", lambda: closed.append(True))
    by_env = evaluate(StraightLinePolicy(), env, suite="linear-1", episodes=2, fidelity=False)
    by_id = evaluate(StraightLinePolicy(), ENV_ID, suite="linear-1", episodes=2, fidelity=False)
    assert [r.final_error for r in by_env.records] == [r.final_error for r in by_id.records]
    assert by_env.summary["env_id"] == ENV_ID
    assert not closed  # the caller owns it
    with pytest.raises(ValueError, match="env must be a dlo_env environment or its id"):
        evaluate(StraightLinePolicy(), 3)
    with pytest.raises(ValueError, match="env must end its episodes"):
        evaluate(StraightLinePolicy(), env.unwrapped)  # no TimeLimit: it could run forever
    with pytest.raises(ValueError, match="not both"):
        evaluate(StraightLinePolicy(), env, env_id=ENV_ID)
