"""Score the latent-tree planner (open and closed loop) and the straight-line reference.

    python examples/evaluate_planner.py --difficulty 2 --episodes 20
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import torch

from latent_model import ShapeModel
from planners import PlannerPolicy, StraightLinePolicy, evaluate, format_table


@dataclass
class Args:
    difficulty: int = 2
    """straight head moves from start to goal"""
    episodes: int = 20
    """episodes per agent"""
    seed: int = 0
    """episode i resets with seed + i"""
    replan_every: int = 10
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

    model = ShapeModel.load_or_pretrained(args.model, device="cpu")
    agents = {
        "straight-line": StraightLinePolicy(),
        "latent-tree": PlannerPolicy(model),
        "latent-tree-closed": PlannerPolicy(model, replan_every=args.replan_every),
    }
    summaries = []
    for name, policy in agents.items():
        result = evaluate(policy, "dlo_env/DLOEndpoint-v0", difficulty=args.difficulty,
                          episodes=args.episodes, seed=args.seed, agent=name)
        summaries.append(result.summary)
    print(format_table(summaries))
