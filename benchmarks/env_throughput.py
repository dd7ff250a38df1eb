"""Environment throughput: env steps/s, the pymunk physics inside them, async vector envs.

The floor: one ``env.step`` costs at most 1.25x the pymunk ``Space.step`` calls it runs.
Every number is measured in this run. The same seeded random actions are run twice per
repeat, once plain (env time) and once with ``pymunk.Space.step`` wrapped in a timer (physics
time); the best of ``repeats`` is kept for each, which filters out other processes on the
machine.

Usage::

    python benchmarks/env_throughput.py [--steps 2000] [--repeats 3] [--vector-steps 300]
"""

from __future__ import annotations

import argparse
import os
import time
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
import pymunk

import dlo_env  # noqa: F401  (registers the environments)

FLOOR = 1.25


@dataclass(frozen=True)
class Args:
    """Benchmark settings."""

    steps: int = 2000
    repeats: int = 3
    vector_steps: int = 300
    num_envs: tuple[int, ...] = (1, 2, 4)
    seed: int = 0


def run_steps(env: gym.Env, actions: np.ndarray, seed: int) -> tuple[float, int]:
    """Time ``env.step`` over ``actions`` (resets excluded); returns seconds and resets."""
    env.reset(seed=seed)
    spent, resets = 0.0, 0
    for a in actions:
        t = time.perf_counter()
        _, _, terminated, truncated, _ = env.step(a)
        spent += time.perf_counter() - t
        if terminated or truncated:
            env.reset()
            resets += 1
    return spent, resets


def physics_time(env: gym.Env, actions: np.ndarray, seed: int) -> tuple[float, int]:
    """The same rollout with every ``pymunk.Space.step`` timed; returns seconds and calls."""
    original = pymunk.Space.step
    spent = [0.0, 0]
    run_steps(env, actions[:1], seed)  # warm-up outside the timer

    def timed(space: pymunk.Space, dt: float) -> None:
        t = time.perf_counter()
        original(space, dt)
        spent[0] += time.perf_counter() - t
        spent[1] += 1

    pymunk.Space.step = timed
    try:
        env.reset(seed=seed)
        spent[0], spent[1] = 0.0, 0
        for a in actions:
            _, _, terminated, truncated, _ = env.step(a)
            if terminated or truncated:
                kept = spent[0], spent[1]
                env.reset()  # its task generation runs physics too: not counted
                spent[0], spent[1] = kept
    finally:
        pymunk.Space.step = original
    return spent[0], spent[1]


def single_env(env_id: str, args: Args) -> None:
    """Print steps/s, physics time and their ratio for one env, raw and as made by gym."""
    rng = np.random.default_rng(args.seed)
    raw = gym.make(env_id).unwrapped
    actions = rng.uniform(-1, 1, size=(args.steps, raw.action_space.shape[0])).astype(np.float32)
    # Max-time rollout: every step runs at the largest speed, half of them on diagonals.
    env_s = min(run_steps(raw, actions, args.seed)[0] for _ in range(args.repeats))
    phys = [physics_time(raw, actions, args.seed) for _ in range(args.repeats)]
    phys_s, calls = min(p[0] for p in phys), phys[0][1]
    wrapped = gym.make(env_id)
    wrapped_s = min(run_steps(wrapped, actions, args.seed)[0] for _ in range(args.repeats))
    ratio = env_s / phys_s
    print(f"{env_id}")
    print(f"  env.step (unwrapped)     {args.steps / env_s:8.0f} steps/s  "
          f"{1e6 * env_s / args.steps:7.1f} us/step")
    print(f"  env.step (gym.make)      {args.steps / wrapped_s:8.0f} steps/s  "
          f"{1e6 * wrapped_s / args.steps:7.1f} us/step")
    print(f"  pymunk Space.step inside {calls / args.steps:8.1f} calls/step "
          f"{1e6 * phys_s / args.steps:7.1f} us/step  ({1e6 * phys_s / calls:.1f} us/call)")
    verdict = "ok" if ratio <= FLOOR else "ABOVE FLOOR"
    print(f"  ratio env.step / physics {ratio:8.3f}  (floor {FLOOR}: {verdict}); "
          f"gym.make wrappers: {wrapped_s / phys_s:.3f}")


def vector_envs(env_id: str, args: Args) -> None:
    """Print total steps/s of ``gym.make_vec(..., vectorization_mode="async")``."""
    print(f"{env_id}, async vector envs ({args.vector_steps} steps each)")
    base = None
    for k in args.num_envs:
        envs = gym.make_vec(env_id, num_envs=k, vectorization_mode="async")
        try:
            envs.reset(seed=args.seed)
            envs.action_space.seed(args.seed)
            batch = [envs.action_space.sample() for _ in range(args.vector_steps)]
            envs.step(batch[0])
            t = time.perf_counter()
            for a in batch:
                envs.step(a)
            rate = k * args.vector_steps / (time.perf_counter() - t)
        finally:
            envs.close()
        base = base or rate
        print(f"  {k} env(s): {rate:8.0f} steps/s  ({rate / base:.2f}x one env)")


def main() -> None:
    """Parse arguments and run every benchmark."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for name, value in vars(Args()).items():
        if not isinstance(value, tuple):
            parser.add_argument(f"--{name.replace('_', '-')}", type=type(value), default=value)
    args = Args(**vars(parser.parse_args()))
    print(f"pymunk {pymunk.version}, gymnasium {gym.__version__}, numpy {np.__version__}, "
          f"{os.cpu_count()} CPUs; {args.steps} random steps, best of {args.repeats}")
    for env_id in ("dlo_env/DLOEndpoint-v0", "dlo_env/DLODualEndpoint-v0"):
        single_env(env_id, args)
    vector_envs("dlo_env/DLOEndpoint-v0", args)


if __name__ == "__main__":
    main()
