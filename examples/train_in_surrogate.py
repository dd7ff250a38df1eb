"""Train Stable-Baselines3 in the learned cord, then score the policy on the pymunk cord.

    python examples/train_in_surrogate.py                          # tiny: about a minute
    python examples/train_in_surrogate.py --timesteps 2000000 --algo sac-her

The surrogate environment (``dlo_env/DLOEndpointSurrogate-v0``) steps ``num_envs`` learned
cords in one batched call of the transition model; ``SB3VecEnv`` hands the batch to SB3 as its
``VecEnv``. The trained policy then acts, unchanged, in ``dlo_env/DLOEndpoint-v0`` (same spaces
and reward), and ``evaluate`` judges it there on a suite's test tasks, at rest, at 1 cm. Every
training step is a surrogate step: none is a pymunk step.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from pathlib import Path

import gymnasium as gym
import torch
from stable_baselines3 import PPO, SAC, HerReplayBuffer
from stable_baselines3.common.vec_env import VecMonitor

import dlo_env  # noqa: F401  (registers the environments)
from dlo_bench import evaluate
from dlo_bench.sb3_vec_env import SB3VecEnv


@dataclass
class Args:
    algo: str = "ppo"
    """ppo or sac-her"""
    timesteps: int = 100_000
    """surrogate steps of training, summed over the cords"""
    num_envs: int = 256
    """cords stepped in one batched call"""
    suite: str = "linear-1"
    """suite whose test tasks score the policy in pymunk"""
    episodes: int = 20
    """test tasks scored"""
    seed: int = 0
    """seed of the agent and the surrogate"""
    out: str = "runs/examples/train_in_surrogate"
    """folder of the trained model"""


def parse_args() -> Args:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for name, default in vars(Args()).items():
        parser.add_argument(f"--{name.replace('_', '-')}", dest=name, type=type(default),
                            default=default)
    return Args(**vars(parser.parse_args()))


def make_model(args: Args) -> PPO | SAC:
    """The SB3 model of ``args.algo`` on the surrogate's batch of cords."""
    venv = gym.make_vec("dlo_env/DLOEndpointSurrogate-v0", num_envs=args.num_envs,
                        vectorization_mode="vector_entry_point", autoreset_mode="same_step",
                        difficulty=(1, 2, 3), success_threshold=0.01, device="cpu")
    env = VecMonitor(SB3VecEnv(venv), info_keywords=("is_success",))
    env.seed(args.seed)
    if args.algo == "ppo":
        return PPO("MultiInputPolicy", env, n_steps=32, batch_size=1024, gamma=0.98,
                   seed=args.seed, verbose=0)
    if args.algo == "sac-her":
        return SAC("MultiInputPolicy", env, replay_buffer_class=HerReplayBuffer,
                   learning_starts=100 * args.num_envs + 1, gradient_steps=8, gamma=0.98,
                   seed=args.seed, verbose=0)
    raise SystemExit(f"--algo must be ppo or sac-her, got {args.algo!r}")


def main() -> None:
    args = parse_args()
    torch.manual_seed(args.seed)
    model = make_model(args)
    t0 = time.perf_counter()
    model.learn(total_timesteps=args.timesteps)
    seconds = time.perf_counter() - t0
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    model.save(out / "model.zip")
    print(f"trained {args.algo} for {model.num_timesteps} surrogate steps (0 pymunk steps) in "
          f"{seconds:.0f} s -> {out / 'model.zip'}")
    result = evaluate(model, "dlo_env/DLOEndpoint-v0", suite=args.suite,
                      episodes=args.episodes, env_kwargs={"success_threshold": 0.01})
    print(f"in pymunk, {args.suite} test tasks, at rest within 1 cm: "
          f"{result.summary['success_rate']:.0%} of {args.episodes}")


if __name__ == "__main__":
    main()
