"""Solve one task with the planners on the learned transition model, next to physics-mpc.

latent-mpc (CEM over straight moves scored by the transition model) and latent-tree-kino (the
latent tree whose edges are predicted moves) against physics-mpc (the simulator as the model),
closed loop on the same task; with ``--dual`` in ``DLODualEndpoint-v0`` (both ends held, each
moving in straight lines).

    python examples/learned_model_planners.py --difficulty 3 --seed 4
    python examples/learned_model_planners.py --difficulty 2 --dual
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
import torch

import dlo_env  # noqa: F401  (registers the environments)
from dlo_bench import build_agent

#: The planners compared, each in both environments.
AGENTS = ("latent-mpc", "physics-mpc", "latent-tree-kino")


@dataclass
class Args:
    seed: int = 0
    """seed of the task"""
    difficulty: int = 3
    """straight moves from start to goal (1-5)"""
    dual: bool = False
    """both ends held (DLODualEndpoint-v0)"""


def parse_args() -> Args:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=Args.seed, help="seed of the task")
    parser.add_argument("--difficulty", type=int, default=Args.difficulty,
                        help="straight moves from start to goal (1-5)")
    parser.add_argument("--dual", action="store_true", help="both ends held")
    return Args(**vars(parser.parse_args()))


if __name__ == "__main__":
    args = parse_args()
    torch.set_num_threads(1)  # small models: more threads only contend
    env_id = "dlo_env/DLODualEndpoint-v0" if args.dual else "dlo_env/DLOEndpoint-v0"
    with gym.make(env_id) as env:
        threshold = env.unwrapped.success_threshold  # the environment's default
    print(f"{env_id}, difficulty {args.difficulty}, task seed {args.seed}; solved: the cord at "
          f"rest within {100 * threshold:g} cm of the goal")
    for name in AGENTS:
        with gym.make(env_id) as env:
            policy = build_agent(name, env)
            obs, info = env.reset(seed=args.seed, options={"difficulty": args.difficulty})
            start_error = info["error"]
            action, _ = policy.predict(obs, episode_start=np.array([True]))
            steps, done = 0, False
            while not done:  # the registered time limit truncates at 100 steps
                obs, _, terminated, truncated, info = env.step(action)
                steps, done = steps + 1, terminated or truncated
                action, _ = policy.predict(obs)
            stats = policy.episode_stats()
            print(f"  {name:<17} {'solved' if info['is_success'] else 'not solved':<10} "
                  f"error {100 * start_error:5.1f} -> {100 * info['error']:4.2f} cm in {steps:3d} "
                  f"steps; {stats.plans} plans, {stats.seconds:.3f} s planning")
