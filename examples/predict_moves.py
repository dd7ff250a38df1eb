"""Predict what a task's moves do with the transition model, and check it against the simulator.

The task's goal is what the simulator made of the start after its straight moves. The
transition model chains one prediction per move from the start; the simulator replays the
same moves rest to rest. Both are compared with the goal (mean point distance).

    python examples/predict_moves.py --difficulty 3 --seed 4 --grasp head
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np

from dlo_env.cord import Cord
from dlo_env.shapes import error
from dlo_env.tasks import apply_action, make_task, split_move, wait_for_rest
from latent_model import TransitionModel


@dataclass
class Args:
    seed: int = 0
    """seed of the task"""
    difficulty: int = 3
    """straight moves from start to goal"""
    grasp: str = "head"
    """held ends: head, tail or both"""
    model: str = ""
    """a transition model file (default: the shipped one)"""


def parse_args() -> Args:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for name, default in vars(Args()).items():
        parser.add_argument(f"--{name}", type=type(default), default=default)
    return Args(**vars(parser.parse_args()))


def main(args: Args) -> None:
    task = make_task(args.seed, args.difficulty, args.grasp)
    model = TransitionModel.load_or_pretrained(args.model or None, device="cpu")
    predicted, simulated = task.start, task.start
    for k, move in enumerate(task.moves, start=1):
        predicted, spread = model.predict(predicted, task.grasp, move, return_std=True)
        cord = Cord(grasp=task.grasp)
        cord.reset(simulated)
        for action in split_move(move, task.max_step):
            apply_action(cord, action, task.max_step)
        wait_for_rest(cord)
        simulated = cord.shape
        print(f"move {k}: {100 * np.linalg.norm(move.reshape(-1, 2), axis=1).max():5.1f} cm; "
              f"model vs simulator {100 * error(predicted, simulated):.2f} cm "
              f"(ensemble spread {100 * spread:.2f} cm)")
    print(f"final shape vs goal: model {100 * error(predicted, task.goal):.2f} cm, "
          f"simulator rest to rest {100 * error(simulated, task.goal):.2f} cm")


if __name__ == "__main__":
    main(parse_args())
