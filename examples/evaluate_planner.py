"""Score the latent-tree planner (open and closed loop) and the straight-line reference.

    python examples/evaluate_planner.py --difficulty 2 --episodes 20
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import gymnasium as gym
import torch

import dlo_env  # noqa: F401  (registers the environments)
from dlo_bench import build_agent, evaluate, format_table
from dlo_bench.agents import load_shape_model
from dlo_bench.report import format_legend
from planners.policy import DEFAULT_REPLAN_EVERY


@dataclass
class Args:
    difficulty: int = 2
    """straight head moves from start to goal"""
    episodes: int = 20
    """episodes per agent"""
    seed: int = 0
    """episode i resets with seed + i"""
    replan_every: int = DEFAULT_REPLAN_EVERY
    """steps between replans of the closed-loop planner"""
    model: str = ""
    """a shape model file (default: the shipped pretrained model)"""


def parse_args() -> Args:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for name, default in vars(Args()).items():
        parser.add_argument(f"--{name.replace('_', '-')}", dest=name, type=type(default),
                            default=default)
    return Args(**vars(parser.parse_args()))


if __name__ == "__main__":
    args = parse_args()
    torch.set_num_threads(1)  # a small model: more threads only contend

    env_id = "dlo_env/DLOEndpoint-v0"
    model = load_shape_model(args.model or None)  # loaded once, shared by both planners
    summaries = []
    for name in ("straight-line", "latent-tree", "latent-tree-closed"):
        policy = build_agent(name, env_id, model=model, seed=args.seed,
                             replan_every=args.replan_every)
        result = evaluate(policy, env_id, difficulty=args.difficulty,
                          episodes=args.episodes, seed=args.seed, agent=name)
        summaries.append(result.summary)
    print(format_table(summaries))
    with gym.make(env_id) as env:
        print(format_legend(env.unwrapped.success_threshold))  # the default, 2 cm
