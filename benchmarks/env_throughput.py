"""Environment throughput: env steps/s, the pymunk physics inside them, async vector envs.

The floor: over ``steps`` random actions (3 000 by default), resets included, ``env.step``
costs at most 1.15x the pymunk ``Space.step`` calls it runs. Every number is measured in this
run. The ratio is measured inside one rollout: every ``env.step`` is timed and, during the same
calls, every ``pymunk.Space.step`` (wrapped in a timer), so load from other processes on the
machine falls on both sides alike. The timer wrapper itself is counted as env overhead, so the
ratio errs on the high side. The rollout resets the environment whenever an episode ends (the
time limit of ``gym.make``, or success): the steps after each reset are measured, and the
resets themselves are timed apart (with the physics they run) and printed as a second ratio,
steps and resets together. Steps/s are also given for the same rollout without any timer.
Each measurement is repeated ``repeats`` times; the median ratio and the best (fastest)
steps/s are printed.

Usage::

    python benchmarks/env_throughput.py [--steps 3000] [--repeats 3] [--vector-steps 300]

``--vector-steps 0`` skips the async vector envs.
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

FLOOR = 1.15


@dataclass(frozen=True)
class Args:
    """Benchmark settings."""

    steps: int = 3000
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
        """The seconds and calls added up so far; starts again from zero."""
        out = self.seconds, self.calls
        self.seconds, self.calls = 0.0, 0
        return out


_PHYSICS = _PhysicsTimer()


@dataclass(frozen=True)
class Rollout:
    """Seconds of one rollout: inside ``env.step``, inside the resets, and inside
    ``pymunk.Space.step`` during each (0 unless the timer is installed)."""

    step_s: float
    reset_s: float
    step_physics_s: float
    reset_physics_s: float
    calls: int  # Space.step calls inside env.step
    resets: int

    @property
    def ratio(self) -> float:
        """env.step time over the physics it runs."""
        return self.step_s / self.step_physics_s

    @property
    def ratio_with_resets(self) -> float:
        """env.step and reset time over the physics they run."""
        return (self.step_s + self.reset_s) / (self.step_physics_s + self.reset_physics_s)


def rollout(env: gym.Env, actions: np.ndarray, seed: int) -> Rollout:
    """Step ``env`` through ``actions``, resetting when an episode ends."""
    env.reset(seed=seed)
    step_s = reset_s = reset_phys = 0.0
    resets = reset_calls = 0
    _PHYSICS.take()
    _PHYSICS.on = True
    for a in actions:
        t = time.perf_counter()
        _, _, terminated, truncated, _ = env.step(a)
        step_s += time.perf_counter() - t
        if terminated or truncated:  # resets draw tasks with physics too: counted apart
            phys, calls = _PHYSICS.seconds, _PHYSICS.calls
            t = time.perf_counter()
            env.reset()
            reset_s += time.perf_counter() - t
            reset_phys += _PHYSICS.seconds - phys
            reset_calls += _PHYSICS.calls - calls
            resets += 1
    _PHYSICS.on = False
    phys_s, calls = _PHYSICS.take()
    return Rollout(step_s, reset_s, phys_s - reset_phys, reset_phys, calls - reset_calls, resets)


def measure(env: gym.Env, actions: np.ndarray, args: Args) -> tuple[list[Rollout], float]:
    """The instrumented rollouts, and the best env.step seconds of plain ones (no timers)."""
    rollout(env, actions[:20], args.seed)  # warm-up
    plain = min(rollout(env, actions, args.seed).step_s for _ in range(args.repeats))
    _PHYSICS.install()
    try:
        timed = [rollout(env, actions, args.seed) for _ in range(args.repeats)]
    finally:
        _PHYSICS.uninstall()
    return timed, plain


def single_env(env_id: str, args: Args) -> bool:
    """Print steps/s, physics time and their ratio for one env, bare and as made by gym."""
    rng = np.random.default_rng(args.seed)
    bare = gym.make(env_id).unwrapped
    actions = rng.uniform(-1, 1, size=(args.steps, bare.action_space.shape[0])).astype(np.float32)
    # Random actions: every step runs at up to the largest speed, many on diagonals.
    print(f"{env_id}")
    ok = True
    for label, env in (("unwrapped", bare), ("gym.make", gym.make(env_id))):
        timed, plain = measure(env, actions, args)
        ratio = statistics.median(r.ratio for r in timed)
        ok &= ratio <= FLOOR
        fast = min(timed, key=lambda r: r.step_s)
        print(f"  env.step ({label:9s})   {args.steps / plain:8.0f} steps/s  "
              f"{1e6 * plain / args.steps:7.1f} us/step (no timers); with timers "
              f"{1e6 * fast.step_s / args.steps:7.1f} us/step")
        print(f"    pymunk Space.step inside {fast.calls / args.steps:6.1f} calls/step "
              f"{1e6 * fast.step_physics_s / args.steps:7.1f} us/step  "
              f"({1e6 * fast.step_physics_s / fast.calls:.1f} us/call)")
        verdict = "ok" if ratio <= FLOOR else "ABOVE FLOOR"
        print(f"    ratio env.step / physics (same rollout): median {ratio:.3f}, per repeat "
              f"{', '.join(f'{r.ratio:.3f}' for r in timed)}  (floor {FLOOR}: {verdict})")
        if fast.resets:
            both = statistics.median(r.ratio_with_resets for r in timed)
            print(f"    {fast.resets} resets, {1e3 * fast.reset_s / fast.resets:.1f} ms each; "
                  f"ratio (env.step + reset) / physics: median {both:.3f}")
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
    for name, least in (("steps", 1), ("repeats", 1), ("vector_steps", 0)):
        if getattr(args, name) < least:
            parser.error(f"--{name.replace('_', '-')} must be >= {least}, "
                         f"got {getattr(args, name)}")
    print(f"pymunk {pymunk.version}, gymnasium {gym.__version__}, numpy {np.__version__}, "
          f"{os.cpu_count()} CPUs; {args.steps} random steps, {args.repeats} repeats")
    print(f"load average at start: {os.getloadavg()[0]:.2f} (other processes share the cores)")
    ok = True
    for env_id in ("dlo_env/DLOEndpoint-v0", "dlo_env/DLODualEndpoint-v0"):
        ok &= single_env(env_id, args)
    print(f"floor env.step <= {FLOOR}x physics (both envs, bare and gym.make): "
          f"{'PASS' if ok else 'FAIL'}")
    if args.vector_steps:
        vector_envs("dlo_env/DLOEndpoint-v0", args)


if __name__ == "__main__":
    main()
