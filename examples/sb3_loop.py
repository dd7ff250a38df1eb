"""Every agent in the plain Stable-Baselines3 loop, with and without ``episode_start``.

    python examples/sb3_loop.py --suite linear-2 --episodes 10

A plain loop (``obs, info = env.reset()`` then ``policy.predict(obs)`` until the episode
ends) does not tell a policy where an episode starts; SB3's ``evaluate_policy`` passes
``episode_start``. The planners notice a new episode either way, so both columns agree. The
last column runs the same tasks in a Gymnasium vector env of 2 environments with one policy
(``predict`` on the batch: one plan per environment; ``physics-mpc-true-cord``, which reads the
cord of the environment it was built from, one policy per environment).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
import torch

import dlo_env  # noqa: F401  (registers the environments)
from dlo_bench import AGENTS, build_agent
from dlo_bench.agents import agent_spec
from dlo_env.tasks import Task, load_suite
from planners import PerEnvPolicy
from planners.interfaces import Policy


@dataclass
class Args:
    suite: str = "linear-2"
    """named suite whose test tasks are run"""
    episodes: int = 10
    """tasks of the suite (the first ones of its test split)"""
    env: str = "dlo_env/DLOEndpoint-v0"
    """environment id"""
    agents: str = ""
    """comma-separated agent names (default: every agent that acts in --env)"""


def parse_args() -> Args:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for name, default in vars(Args()).items():
        parser.add_argument(f"--{name}", dest=name, type=type(default), default=default)
    return Args(**vars(parser.parse_args()))


def plain_loop(policy: Policy, env: gym.Env, tasks: list[Task], tell_starts: bool
               ) -> list[bool]:
    """Success of each task, one environment, the loop a user writes by hand."""
    solved = []
    for task in tasks:
        obs, info = env.reset(options={"task": task})
        first = True
        while True:
            start = np.array([first]) if tell_starts else None
            action, _ = policy.predict(obs, episode_start=start, deterministic=True)
            first = False
            obs, _, terminated, truncated, info = env.step(action)
            if terminated or truncated:
                break
        solved.append(bool(info["is_success"]))
    return solved


class TaskSequence(gym.Wrapper):
    """An environment whose resets run ``tasks`` in order (then the last one again)."""

    def __init__(self, env: gym.Env, tasks: list[Task]) -> None:
        super().__init__(env)
        self.tasks, self.started = list(tasks), 0

    def reset(self, *, seed=None, options=None):
        task = self.tasks[min(self.started, len(self.tasks) - 1)]
        self.started += 1
        return self.env.reset(seed=seed, options={"task": task})


def vector_loop(name: str, env_id: str, tasks: list[Task], num_envs: int = 2) -> list[bool]:
    """Success of each task, ``num_envs`` environments at a time in a Gymnasium vector env
    (one batched ``predict`` per step, no ``episode_start``; finished episodes reset
    themselves, as vector envs do). A policy that plans for one environment only
    (``plans_batches`` False) gets one copy per environment (``PerEnvPolicy``)."""
    num_envs = min(num_envs, len(tasks))
    shares = [tasks[i::num_envs] for i in range(num_envs)]
    envs = gym.vector.SyncVectorEnv(
        [lambda share=share: TaskSequence(gym.make(env_id), share) for share in shares])
    policy = build_agent(name, envs.envs[0])
    if not getattr(policy, "plans_batches", True):
        policy = PerEnvPolicy([build_agent(name, e) for e in envs.envs])
    results: list[list[bool]] = [[] for _ in shares]
    obs, _ = envs.reset()
    while any(len(r) < len(share) for r, share in zip(results, shares)):
        actions, _ = policy.predict(obs, deterministic=True)
        obs, _, terminated, truncated, infos = envs.step(actions)
        for i in np.flatnonzero(terminated | truncated):
            if len(results[i]) < len(shares[i]):
                results[i].append(bool(infos["is_success"][i]))
    envs.close()
    return [results[k % num_envs][k // num_envs] for k in range(len(tasks))]  # task order


if __name__ == "__main__":
    args = parse_args()
    torch.set_num_threads(1)
    names = [a for a in args.agents.split(",") if a] or [
        name for name, spec in AGENTS.items() if args.env in spec.environments]
    env = gym.make(args.env)
    tasks = load_suite(args.suite, "test", grasp=env.unwrapped.grasp, limit=args.episodes)
    print(f"{args.suite} test tasks 1-{len(tasks)}, {args.env}: tasks solved")
    print(f"{'agent':<20} {'with episode_start':>19} {'without':>8} {'vector env x2':>14} "
          f"{'seconds':>8}")
    for name in names:
        t0 = time.perf_counter()
        spec = agent_spec(name)
        if args.env not in spec.environments:
            print(f"{name:<20} not run: it acts in {', '.join(spec.environments)}")
            continue
        try:
            first = build_agent(name, env)
        except FileNotFoundError as exc:  # no shipped model for this environment
            print(f"{name:<20} not run: {exc}")
            continue
        told = plain_loop(first, env, tasks, tell_starts=True)
        plain = plain_loop(build_agent(name, env), env, tasks, tell_starts=False)
        vector = vector_loop(name, args.env, tasks)
        print(f"{name:<20} {sum(told):>19} {sum(plain):>8} {sum(vector):>14} "
              f"{time.perf_counter() - t0:>8.0f}", flush=True)
