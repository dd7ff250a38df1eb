"""One episode of the cord environment: random actions, or the task's reference actions.

    python examples/random_episode.py --difficulty 2
    python examples/random_episode.py --policy reference --gif runs/examples/episode.gif

Random actions rarely solve a task; the reference actions (the moves that made the goal,
returned by ``reset``) always do. ``--gif`` needs pillow and pygame-ce (the ``render`` extra).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import gymnasium as gym
import numpy as np

import dlo_env  # noqa: F401  (registers the environments)


@dataclass
class Args:
    env_id: str = "dlo_env/DLOEndpoint-v0"
    """the environment (or dlo_env/DLODualEndpoint-v0)"""
    seed: int = 0
    """seed of the task and of the random actions"""
    difficulty: int = 1
    """straight moves from the start to the goal, 1-5"""
    policy: str = "random"
    """'random' or 'reference' (replay the moves that made the goal)"""
    gif: str = ""
    """write the episode to this GIF file"""


def parse_args() -> Args:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for name, default in vars(Args()).items():
        parser.add_argument(f"--{name.replace('_', '-')}", type=type(default), default=default)
    args = Args(**vars(parser.parse_args()))
    if args.policy not in ("random", "reference"):
        parser.error(f"--policy must be 'random' or 'reference', got {args.policy!r}")
    return args


if __name__ == "__main__":
    args = parse_args()
    env = gym.make(args.env_id, render_mode="rgb_array" if args.gif else None)
    obs, info = env.reset(seed=args.seed, options={"difficulty": args.difficulty})
    env.action_space.seed(args.seed)
    reference = list(info["reference_actions"])
    print(f"{args.env_id}, difficulty {args.difficulty}: start is {100 * info['error']:.1f} cm "
          f"from the goal (mean point distance); the reference solves it in {len(reference)} "
          f"steps; {args.policy} actions")

    frames = [env.render()] if args.gif else []
    terminated = truncated = False
    step = 0
    while not (terminated or truncated):
        if args.policy == "reference":
            # After the reference actions, hold still (the time limit ends the episode).
            action = reference[step] if step < len(reference) else np.zeros_like(reference[0])
        else:
            action = env.action_space.sample()
        obs, reward, terminated, truncated, info = env.step(action)
        step += 1
        print(f"step {step:3d}  action {np.array2string(action, precision=2)}  "
              f"error {100 * info['error']:5.2f} cm  max error {100 * info['max_error']:5.2f} cm")
        if args.gif:
            frames.append(env.render())
    env.close()

    ending = "terminated: success" if terminated else "truncated: time limit (100 steps)"
    print(f"{ending}; is_success={info['is_success']}, final error "
          f"{100 * info['error']:.2f} cm (success threshold 2 cm)")

    if args.gif:
        from PIL import Image

        from dlo_env.core.atomic import atomic_path

        images = [Image.fromarray(f) for f in frames]
        fps = env.metadata["render_fps"]
        with atomic_path(args.gif) as tmp:  # makes the folder; a crash leaves no half file
            images[0].save(tmp, save_all=True, append_images=images[1:],
                           duration=round(1000 / fps), loop=0)
        print(f"wrote {args.gif} ({len(images)} frames)")
