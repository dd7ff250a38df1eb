"""Specification: the documented environment ids work in a fresh ``python -c`` process, whose
vector-env workers have not imported ``dlo_env`` (Gymnasium 1.x has no plugin entry points).

Each case runs in its own interpreter started with ``-c``, exactly as a user's one-liner or a
notebook kernel would: pytest's process has imported ``dlo_env`` already and would hide the
problem.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

QUALIFIED = "dlo_env:dlo_env/DLOEndpoint-v0"
QUALIFIED_DUAL = "dlo_env:dlo_env/DLODualEndpoint-v0"


def run_python_c(code: str, cwd) -> str:
    """Run ``python -c code`` in ``cwd``; its stdout, or a failure showing its stderr."""
    result = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], cwd=cwd,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-3000:]
    return result.stdout


@pytest.mark.slow
@pytest.mark.parametrize("env_id", [QUALIFIED, QUALIFIED_DUAL])
def test_qualified_id_runs_in_sb3_subproc_vec_env_from_python_c(env_id, tmp_path):
    pytest.importorskip("stable_baselines3", reason="needs the rl extra (stable-baselines3)")
    out = run_python_c(f"""
        import numpy as np
        from stable_baselines3.common.env_util import make_vec_env
        from stable_baselines3.common.vec_env import SubprocVecEnv

        envs = make_vec_env({env_id!r}, n_envs=2, seed=0, vec_env_cls=SubprocVecEnv)
        obs = envs.reset()
        obs, rewards, dones, infos = envs.step(np.zeros((2, envs.action_space.shape[0])))
        print(obs["desired_goal"].shape, rewards.shape, "is_success" in infos[0])
        envs.close()
    """, tmp_path)
    assert out.split() == ["(2,", "40)", "(2,)", "True"]


@pytest.mark.slow
@pytest.mark.parametrize("env_id", [QUALIFIED, QUALIFIED_DUAL])
def test_qualified_id_runs_in_gymnasium_async_vector_env_from_python_c(env_id, tmp_path):
    out = run_python_c(f"""
        import gymnasium as gym
        import numpy as np

        envs = gym.make_vec({env_id!r}, num_envs=2, vectorization_mode="async")
        obs, info = envs.reset(seed=[0, 1])
        obs, rewards, *_ = envs.step(np.zeros(envs.action_space.shape, np.float32))
        print(obs["desired_goal"].shape, rewards.shape)
        envs.close()
    """, tmp_path)
    assert out.split() == ["(2,", "40)", "(2,)"]


@pytest.mark.slow
def test_plain_id_after_import_runs_in_gymnasium_async_vector_env_from_python_c(tmp_path):
    # gym.make_vec hands its workers the registered spec (entry point included), so a plain id
    # registered in the parent is enough.
    out = run_python_c("""
        import gymnasium as gym
        import dlo_env

        envs = gym.make_vec("dlo_env/DLOEndpoint-v0", num_envs=2, vectorization_mode="async")
        obs, info = envs.reset(seed=[0, 1])
        print(obs["observation"].shape)
        envs.close()
    """, tmp_path)
    assert out.split() == ["(2,", "42)"]


def test_qualified_id_makes_the_registered_environment_in_a_fresh_process(tmp_path):
    out = run_python_c(f"""
        import gymnasium as gym

        env = gym.make({QUALIFIED!r})
        print(env.spec.id, env.spec.max_episode_steps)
    """, tmp_path)
    assert out.split() == ["dlo_env/DLOEndpoint-v0", "100"]
