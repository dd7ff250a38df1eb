"""Plan a transition with the latent-tree planner, then check it against the simulator.

    python examples/plan_transition.py --difficulty 2 --seed 3
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import gymnasium as gym
import torch

import dlo_env  # noqa: F401  (registers the environments)
from dlo_bench import transition_fidelity
from dlo_env.shapes import error
from latent_model import ShapeModel
from planners import LatentTreePlanner


@dataclass
class Args:
    seed: int = 0
    """seed of the task and of the planner"""
    difficulty: int = 1
    """straight head moves from start to goal"""
    step_length: float = 0.15
    """the paper's l: latent distance of one tree edge"""
    straightness: float = 0.01
    """how far (m) the head may leave the straight line of an edge"""
    model: str = ""
    """a shape model file (default: the shipped pretrained model)"""


def parse_args() -> Args:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for name, default in vars(Args()).items():
        parser.add_argument(f"--{name}", type=type(default), default=default)
    return Args(**vars(parser.parse_args()))


if __name__ == "__main__":
    args = parse_args()
    torch.set_num_threads(1)  # a small model: more threads only contend

    env = gym.make("dlo_env/DLOEndpoint-v0")
    obs, _ = env.reset(seed=args.seed, options={"difficulty": args.difficulty})
    start, goal = obs["achieved_goal"].reshape(-1, 2), obs["desired_goal"].reshape(-1, 2)

    model = ShapeModel.load_or_pretrained(args.model, device="cpu")
    planner = LatentTreePlanner(model, seed=args.seed, step_length=args.step_length,
                                straightness=args.straightness)
    plan = planner.plan(start, goal)
    s = plan.stats
    # The first call includes PyTorch's one-time warm-up (about a second); later plans are fast.
    print(f"success {plan.success}: {s['nodes']} nodes, {s['decoder_calls']} decoder calls, "
          f"{s['seconds']:.3f} s")
    print(f"{len(plan.moves)} straight head moves (m): {plan.moves.round(3).tolist()}")

    # The environment is the judge: execute the head path and compare shapes on the way.
    fidelity = transition_fidelity(plan, start, params=env.unwrapped.cord.params,
                                   max_step=env.unwrapped.max_step)
    print(f"transition fidelity {100 * fidelity.mean_error:.2f} cm (mean over "
          f"{len(plan.shapes)} planned shapes), worst {100 * fidelity.max_error:.2f} cm")
    print(f"real cord at rest after the motion vs the goal: "
          f"{100 * error(fidelity.final_shape, goal):.2f} cm")
