"""The agent registry: one name, one agent, built for the environment it acts in."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import dlo_env  # noqa: F401  (registers the environments)
from dlo_bench import AGENTS, build_agent
from dlo_bench.agents import DUAL_ENDPOINT, ENDPOINT, agent_names
from dlo_bench.paths import shipped_baseline
from planners.interfaces import PlanningPolicy, Policy


def _first_action(policy, env) -> np.ndarray:
    obs, _ = env.reset(seed=0, options={"difficulty": 1})
    action, _ = policy.predict(obs, episode_start=np.array([True]), deterministic=True)
    return np.asarray(action).reshape(-1)


@pytest.mark.parametrize("name", list(AGENTS))
def test_every_registered_agent_acts_in_each_of_its_environments(name, toy_model):
    from dlo_bench.paths import shipped_baseline

    spec = AGENTS[name]
    for env_id in spec.environments:
        with gym.make(env_id) as env:
            if spec.extra == "rl" and not shipped_baseline(name, env_id).is_dir():
                # Trainable there (`dlo baseline --env-id`), but nothing is shipped: one line.
                with pytest.raises(FileNotFoundError, match="dlo baseline --algo") as info:
                    build_agent(name, env)
                assert "\n" not in str(info.value)
                continue
            policy = build_agent(name, env, model=toy_model)
            assert isinstance(policy, Policy)
            action = _first_action(policy, env)
            assert env.action_space.contains(action.astype(np.float32))


@pytest.mark.parametrize("name", list(AGENTS))
def test_an_agent_refuses_the_observations_of_the_environment_it_was_not_built_for(name,
                                                                                   toy_model):
    with gym.make(ENDPOINT) as env, gym.make(DUAL_ENDPOINT) as other:
        if AGENTS[name].extra == "rl" and not shipped_baseline(name, ENDPOINT).is_dir():
            pytest.skip(f"no shipped {name} for {ENDPOINT}")
        policy = build_agent(name, env, model=toy_model)
        obs, _ = other.reset(seed=0, options={"difficulty": 1})
        with pytest.raises(ValueError) as info:  # one line, not a wrong-sized action
            policy.predict(obs, deterministic=True)
        assert "44" in str(info.value) and "42" in str(info.value), info.value


def test_build_agent_takes_an_environment_id_as_evaluate_does():
    policy = build_agent("straight-line", ENDPOINT)
    with gym.make(ENDPOINT) as env:
        assert env.action_space.contains(_first_action(policy, env))
    with pytest.raises(ValueError, match="env must be a dlo_env environment or its id"):
        build_agent("straight-line", 5)


def test_an_sb3_folder_acts_in_the_environment_it_was_trained_in():
    folder = shipped_baseline("ppo", DUAL_ENDPOINT)
    if not folder.is_dir():
        pytest.skip(f"no shipped ppo for {DUAL_ENDPOINT}")
    assert AGENTS.get(f"sb3:{folder}") is None
    with gym.make(DUAL_ENDPOINT) as env:
        assert env.action_space.contains(_first_action(build_agent(f"sb3:{folder}", env), env))
    with pytest.raises(ValueError, match=f"acts in {DUAL_ENDPOINT}, got environment"):
        build_agent(f"sb3:{folder}", ENDPOINT)


def test_build_agent_refuses_a_flattened_environment_in_one_line():
    with gym.wrappers.FlattenObservation(gym.make(ENDPOINT)) as env:
        with pytest.raises(ValueError, match="env must observe the dlo_env Dict") as info:
            build_agent("straight-line", env)
        assert "\n" not in str(info.value)


def test_planners_report_their_statistics_through_the_planning_protocol(toy_model):
    with gym.make(ENDPOINT) as env:
        for name in ("latent-tree", "latent-tree-closed", "physics-mpc"):
            policy = build_agent(name, env, model=toy_model)
            assert isinstance(policy, PlanningPolicy)
            _first_action(policy, env)
            assert policy.episode_stats().plans == 1
        assert not isinstance(build_agent("straight-line", env), PlanningPolicy)


def test_closed_loop_agent_takes_the_replanning_interval_and_open_loop_ignores_it(toy_model):
    with gym.make(ENDPOINT) as env:
        assert build_agent("latent-tree-closed", env, model=toy_model,
                           replan_every=7).replan_every == 7
        assert build_agent("latent-tree", env, model=toy_model, replan_every=7).replan_every \
            is None


def test_build_agent_rejects_an_unknown_option():
    with gym.make(ENDPOINT) as env, pytest.raises(ValueError, match="options must be some of"):
        build_agent("straight-line", env, replan_evry=3)


def test_build_agent_rejects_an_environment_the_agent_does_not_act_in(monkeypatch):
    from dataclasses import replace

    from dlo_bench import agents

    spec = replace(agents.AGENTS["straight-line"], environments=("dlo_env/DLOEndpoint-v0",))
    monkeypatch.setitem(agents.AGENTS, "straight-line", spec)
    with gym.make(DUAL_ENDPOINT) as env, pytest.raises(ValueError, match="acts in"):
        build_agent("straight-line", env)


def test_every_registered_agent_acts_in_both_environments():
    assert all(set(spec.environments) == {"dlo_env/DLOEndpoint-v0", DUAL_ENDPOINT}
               for spec in AGENTS.values())


def test_agent_names_list_the_registry_and_the_sb3_form():
    assert agent_names() == (*AGENTS, "sb3:PATH")


def test_shipped_baselines_are_found_from_any_working_directory(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert (shipped_baseline("ppo") / "policy.pt").is_file()
    with gym.make(ENDPOINT) as env:
        assert env.action_space.contains(
            _first_action(build_agent("ppo", env), env).astype(np.float32))


def test_a_baseline_folder_of_another_algorithm_is_rejected():
    with gym.make(ENDPOINT) as env, pytest.raises(ValueError, match="holds a ppo model"):
        build_agent("sac-her", env, baseline=shipped_baseline("ppo"))


def test_the_shipped_ppo_acts_in_the_dual_environment():
    env = gym.make(DUAL_ENDPOINT)
    obs, _ = env.reset(seed=3)
    action, _ = build_agent("ppo", env).predict(obs, deterministic=True)
    assert action.shape == (4,)


def test_a_policy_trained_on_the_empty_table_is_refused_where_pegs_are_observed():
    import gymnasium as gym

    from dlo_bench.paths import shipped_baseline

    with gym.make("dlo_env/DLOEndpoint-v0", max_pegs=2) as env:
        with pytest.raises(ValueError, match=r"agent 'ppo' was trained on observations of shape "
                                             r"\(42,\), but this environment observes \(48,\)"):
            build_agent("ppo", env, baseline=shipped_baseline("ppo"))
        # its default, the shipped ppo-pegs, was trained where 4 pegs are observed
        with pytest.raises(ValueError, match=r"\(54,\), but this environment observes \(48,\)"):
            build_agent("ppo", env)
        build_agent("latent-mpc", env)  # planners read the pegs, or ignore them
    with gym.make("dlo_env/DLOEndpoint-v0", max_pegs=4) as env:
        assert build_agent("ppo", env) is not None
    with gym.make("dlo_env/DLODualEndpoint-v0", max_pegs=4) as env:
        assert build_agent("ppo", env) is not None  # the shipped ppo-pegs-dual-endpoint
    with gym.make("dlo_env/DLODualEndpoint-v0", max_pegs=2) as env:
        with pytest.raises(ValueError, match=r"\(56,\), but this environment observes \(50,\)"):
            build_agent("ppo", env)


@pytest.mark.parametrize("name", ["latent-mpc", "latent-tree-kino"])
def test_planners_on_the_transition_model_pass_it_the_pegs_they_observe(name):
    from dlo_env.peg_suites import load_peg_suite

    task = load_peg_suite("pegs-1", limit=3)[2]  # three pegs
    with gym.make("dlo_env/DLOEndpoint-v0", max_pegs=4) as env:
        policy = build_agent(name, env)
        model = policy.planner.transition_model if name == "latent-tree-kino" else policy.model
        seen = []
        predict = model.predict

        def spy(*args, **kwargs):
            seen.append(kwargs.get("pegs"))
            return predict(*args, **kwargs)

        model.predict = spy
        obs, _ = env.reset(options={"task": task})
        policy.predict(obs, episode_start=np.array([True]), deterministic=True)
    assert seen and all(p is not None and np.array_equal(p, task.pegs) for p in seen)


def test_the_adaptive_planner_fits_the_cord_with_the_pegs_it_observes():
    """A move stopped by a peg is predicted stopped while the cord is fitted, so the contact is
    not blamed on the cord."""
    from dlo_env.peg_suites import load_peg_suite

    task = load_peg_suite("pegs-1", limit=3)[2]
    with gym.make("dlo_env/DLOEndpoint-v0", max_pegs=4) as env:
        policy = build_agent("latent-mpc-adaptive", env)
        seen = []
        predict = policy.model.predict

        def spy(*args, **kwargs):
            seen.append((kwargs.get("params") is not None and np.ndim(kwargs["params"]) == 2,
                         kwargs.get("pegs")))
            return predict(*args, **kwargs)

        policy.model.predict = spy
        obs, _ = env.reset(options={"task": task})
        start = np.array([True])
        for _ in range(40):
            action, _ = policy.predict(obs, episode_start=start, deterministic=True)
            obs, _, done, truncated, _ = env.step(action)
            start = np.array([False])
            if policy.adapt_stats.errors or done or truncated:
                break
    fits = [pegs for fitting, pegs in seen if fitting]  # the fit's calls: a cord per row
    assert policy.adapt_stats.errors and fits
    assert all(p is not None and np.array_equal(p, task.pegs) for p in fits)


def test_a_planner_built_among_pegs_refuses_an_observation_without_peg_slots_naming_them():
    with gym.make(ENDPOINT, max_pegs=4) as pegged, gym.make(ENDPOINT) as plain:
        policy = build_agent("straight-line", pegged)
        obs, _ = plain.reset(seed=0)
        with pytest.raises(ValueError, match="max_pegs=4, which observes 54") as info:
            policy.predict(obs)
        assert "\n" not in str(info.value)
    with pytest.raises(ValueError, match="give it that environment, not its id"):
        build_agent("physics-mpc-true-cord", ENDPOINT)


def test_latent_mpc_offers_the_straight_plan_where_pegs_are_observed_only():
    from planners.latent_mpc import PEGS_SETTINGS

    with gym.make("dlo_env/DLOEndpoint-v0", max_pegs=4) as env:
        among = build_agent("latent-mpc", env).config
    with gym.make("dlo_env/DLOEndpoint-v0") as env:
        empty = build_agent("latent-mpc", env).config
    assert PEGS_SETTINGS and all(getattr(among, k) == v for k, v in PEGS_SETTINGS.items())
    assert not empty.offer_straight and among.samples == empty.samples
