"""Environment throughput: env steps/s, the pymunk physics inside them, async vector envs.

The floor: one ``env.step`` costs at most 1.25x the pymunk ``Space.step`` calls it runs.
Every number is measured in this run. The ratio is measured inside one rollout: every
``env.step`` is timed and, during the same calls, every ``pymunk.Space.step`` (wrapped in a
timer), so load from other processes on the machine falls on both sides alike. The timer
wrapper itself is counted as env overhead, so the ratio errs on the high side. Steps/s are also
given for the same rollout without any timer. Each measurement is repeated ``repeats`` times;
the median ratio and the best (fastest) steps/s are printed.

Usage::

    python benchmarks/env_throughput.py [--steps 2000] [--repeats 3] [--vector-steps 300]
"""

from __future__ import annotations

import argparse
import os
import statistics
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


class _PhysicsTimer:
    """Wraps ``pymunk.Space.step`` to add up its time while ``on``."""

    def __init__(self) -> None:
        self.on = False
        self.seconds = 0.0
        self.calls = 0
        self.original = pymunk.Space.step

    def install(self) -> None:
        original = self.original

        def timed(space: pymunk.Space, dt: float) -> None:
            if not self.on:
                original(space, dt)
                return
            t = time.perf_counter()
            original(space, dt)
            self.seconds += time.perf_counter() - t
            self.calls += 1

        pymunk.Space.step = timed

    def uninstall(self) -> None:
        pymunk.Space.step = self.original

    def take(self) -> tuple[float, int]:
        out = self.seconds, self.calls
        self.seconds, self.calls = 0.0, 0
        return out


_PHYSICS = _PhysicsTimer()


def rollout(env: gym.Env, actions: np.ndarray, seed: int) -> tuple[float, float, int]:
    """Step ``env`` through ``actions`` (resetting when an episode ends).

    Returns:
        Seconds inside ``env.step``, seconds inside ``pymunk.Space.step`` during those calls
        (0 unless the timer is installed), and the number of ``Space.step`` calls.
    """
    env.reset(seed=seed)
    env_s = 0.0
    for a in actions:
        _PHYSICS.on = True
        t = time.perf_counter()
        _, _, terminated, truncated, _ = env.step(a)
        env_s += time.perf_counter() - t
        _PHYSICS.on = False  # resets generate tasks with physics too: not counted
        if terminated or truncated:
            env.reset()
    phys_s, calls = _PHYSICS.take()
    return env_s, phys_s, calls


def measure(env: gym.Env, actions: np.ndarray, args: Args) -> tuple[list[float], float, float,
                                                                   float, int]:
    """Ratios per repeat, best plain and instrumented env seconds, physics seconds, calls."""
    rollout(env, actions[:20], args.seed)  # warm-up
    plain = min(rollout(env, actions, args.seed)[0] for _ in range(args.repeats))
    ratios, timed, physics, calls = [], [], [], 0
    _PHYSICS.install()
    try:
        for _ in range(args.repeats):
            env_s, phys_s, calls = rollout(env, actions, args.seed)
            ratios.append(env_s / phys_s)
            timed.append(env_s)
            physics.append(phys_s)
    finally:
        _PHYSICS.uninstall()
    return ratios, plain, min(timed), min(physics), calls


def single_env(env_id: str, args: Args) -> bool:
    """Print steps/s, physics time and their ratio for one env, bare and as made by gym."""
    rng = np.random.default_rng(args.seed)
    bare = gym.make(env_id).unwrapped
    actions = rng.uniform(-1, 1, size=(args.steps, bare.action_space.shape[0])).astype(np.float32)
    # Random actions: every step runs at up to the largest speed, many on diagonals.
    print(f"{env_id}")
    ok = True
    for label, env in (("unwrapped", bare), ("gym.make", gym.make(env_id))):
        ratios, plain, timed, phys, calls = measure(env, actions, args)
        ratio = statistics.median(ratios)
        ok &= ratio <= FLOOR
        print(f"  env.step ({label:9s})   {args.steps / plain:8.0f} steps/s  "
              f"{1e6 * plain / args.steps:7.1f} us/step (no timers); with timers "
              f"{1e6 * timed / args.steps:7.1f} us/step")
        print(f"    pymunk Space.step inside {calls / args.steps:6.1f} calls/step "
              f"{1e6 * phys / args.steps:7.1f} us/step  ({1e6 * phys / calls:.1f} us/call)")
        verdict = "ok" if ratio <= FLOOR else "ABOVE FLOOR"
        print(f"    ratio env.step / physics (same rollout): median {ratio:.3f}, per repeat "
              f"{', '.join(f'{r:.3f}' for r in ratios)}  (floor {FLOOR}: {verdict})")
    return ok


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
        print(f"  {k} env(s): {rate:8.0f} steps/s in total, {rate / k:6.0f} per env  "
              f"({rate / base:.2f}x one env)")


def main() -> None:
    """Parse arguments and run every benchmark."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for name, value in vars(Args()).items():
        if not isinstance(value, tuple):
            parser.add_argument(f"--{name.replace('_', '-')}", type=type(value), default=value)
    args = Args(**vars(parser.parse_args()))
    print(f"pymunk {pymunk.version}, gymnasium {gym.__version__}, numpy {np.__version__}, "
          f"{os.cpu_count()} CPUs; {args.steps} random steps, {args.repeats} repeats")
    print(f"load average at start: {os.getloadavg()[0]:.2f} (other processes share the cores)")
    ok = True
    for env_id in ("dlo_env/DLOEndpoint-v0", "dlo_env/DLODualEndpoint-v0"):
        ok &= single_env(env_id, args)
    print(f"floor env.step <= {FLOOR}x physics (both envs, bare and gym.make): "
          f"{'PASS' if ok else 'FAIL'}")
    vector_envs("dlo_env/DLOEndpoint-v0", args)


if __name__ == "__main__":
    main()
