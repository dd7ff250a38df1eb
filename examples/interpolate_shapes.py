"""Shape transition by latent interpolation (the paper's Fig. 2) on a random task.

    python examples/interpolate_shapes.py --difficulty 1 --steps 8

It writes runs/examples/interpolation.png (--out elsewhere).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import gymnasium as gym
import torch

import dlo_env  # noqa: F401  (registers the environments)
from dlo_bench.charts import save_interpolation_png
from dlo_env.shapes import error
from latent_model import ShapeModel
from planners import interpolate


@dataclass
class Args:
    seed: int = 0
    """seed of the task"""
    difficulty: int = 1
    """straight head moves from start to goal"""
    steps: int = 8
    """shapes on the latent line"""
    out: str = "runs/examples/interpolation.png"
    """the figure to write"""
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
    shapes = interpolate(model, start, goal, steps=args.steps)  # (steps, n, 2), metres

    print(f"start -> goal: {100 * error(start, goal):.1f} cm apart")
    print(f"decoded ends vs real: start {100 * error(shapes[0], start):.2f} cm, "
          f"goal {100 * error(shapes[-1], goal):.2f} cm (inversion error)")
    save_interpolation_png(args.out, shapes, start, goal, title="latent interpolation")
    print(f"wrote {args.out}")
