"""Transition collection speed: transitions per second in one process and with workers.

Prints the load average first (other jobs on the cores slow the workers down), one process's
rate and its share of time in pymunk, then where that time goes: the physics steps a transition
takes (while the grippers move, while the cord comes to rest, settling each episode's start)
and the time per step, so the rate pymunk alone allows. Then a full ``collect_transitions`` run
with ``--workers`` processes (start-up and the final file included), the CPU time the workers
got, and the floor (at least 150 transitions/s with 2 workers on a quiet machine).

``--iterations N ...`` also replays the chunk's first ``--replay`` moves from their recorded
starts (the default cord of the collection) with ``N`` solver iterations per physics step
instead of the cord's (30): how much
faster, and how far the cord then comes to rest from where the environments' physics puts it.
That is other physics (every shipped model and benchmark is of the cord's own), measured to
show the trade-off, not an option of the collection.

    python benchmarks/transition_throughput.py [--num 4000] [--workers 2] [--seed 0] \
        [--iterations 20 15 10] [--replay 200]
"""

from __future__ import annotations

import argparse
import os
import resource
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import replace

import numpy as np
from collect_throughput import physics_timer  # the script beside this one

from dlo_env.cord import Cord
from dlo_env.dataset.transitions import (
    GRASP_NAMES,
    TransitionCollectConfig,
    TransitionDataset,
    carry_out,
    collect_transition_chunk,
    collect_transitions,
)

RATE_FLOOR = 150.0


@contextmanager
def settle_steps() -> Iterator[list[int]]:
    """Physics steps taken inside ``Cord.settle`` (settling the episodes' starts) while the
    block runs: ``[steps]``."""
    original = Cord.settle
    steps = [0]

    def counted(cord: Cord, *args: object, **kwargs: object) -> float:
        took = original(cord, *args, **kwargs)
        steps[0] += round(took * cord.params.substeps / cord.params.dt)
        return took

    Cord.settle = counted  # type: ignore[method-assign]
    try:
        yield steps
    finally:
        Cord.settle = original  # type: ignore[method-assign]


def single_process(config: TransitionCollectConfig, count: int
                   ) -> tuple[TransitionDataset, float]:
    """One chunk in this process, printing its rate, the share of time in pymunk and where it
    goes; the chunk and its rate (transitions/s)."""
    collect_transition_chunk(config, 10_000, 10)  # warm-up
    with physics_timer() as spent, settle_steps() as settling:
        t = time.perf_counter()
        data = collect_transition_chunk(config, 10_001, count)
        total = time.perf_counter() - t
    n = len(data)
    seconds, steps = spent
    resting = int(data.settle.astype(np.int64).sum()) * config.cord.substeps
    moving = steps - resting - settling[0]
    print(f"1 process : {n / total:6.1f} transitions/s ({seconds / total:.0%} of the time in "
          f"pymunk Space.step)")
    print(f"physics steps per transition: {steps / n:.0f} (grippers moving {moving / n:.0f}, "
          f"coming to rest {resting / n:.0f}, settling the episodes' starts "
          f"{settling[0] / n:.0f}); {1e6 * seconds / steps:.1f} us per step, "
          f"{1e3 * (total - seconds) / n:.2f} ms per transition outside pymunk")
    print(f"pymunk alone allows {n / seconds:.1f} transitions/s per process at this step count "
          f"and solver ({config.cord.iterations} iterations per step)")
    return data, n / total


def replay(config: TransitionCollectConfig, data: TransitionDataset, iterations: int
           ) -> tuple[np.ndarray, float]:
    """The recorded moves carried out again from their recorded starts with ``iterations``
    solver iterations: the shapes at rest ``(T, n, 2)`` and the seconds it took."""
    params = replace(config.cord, iterations=iterations)
    out = np.empty_like(data.next)
    t = time.perf_counter()
    for i in range(len(data)):
        grasp = GRASP_NAMES[int(data.grasp[i])]
        cord = Cord(params, grasp=grasp, pegs=data.peg_list(i), peg_radius=config.peg_radius)
        cord.reset(data.start[i])
        move = data.end_displacement([i])[0].astype(np.float64)
        out[i] = carry_out(cord, move, config.max_step)[0]
    return out, time.perf_counter() - t


def solver_tradeoff(config: TransitionCollectConfig, data: TransitionDataset,
                    iterations: list[int]) -> None:
    """Speed and rest shapes of the same moves with fewer (or more) solver iterations."""
    base, base_s = replay(config, data, config.cord.iterations)
    base_s = min(base_s, replay(config, data, config.cord.iterations)[1])  # the warm one
    print(f"replaying {len(data)} moves from their recorded starts, {config.cord.iterations} "
          f"iterations (the cord's): {len(data) / base_s:.1f} moves/s, mean "
          f"{100 * np.linalg.norm(base - data.next, axis=-1).mean():.3f} cm from the recorded "
          "rest shapes")
    for k in iterations:
        shapes, seconds = replay(config, data, k)
        gap = 100 * np.linalg.norm(shapes - base, axis=-1).mean(axis=-1)  # (T,) cm
        print(f"  {k:3d} iterations: {base_s / seconds:.2f}x as fast; rest shapes from the "
              f"cord's physics: mean {gap.mean():.3f} cm, 99th pct {np.percentile(gap, 99):.3f}, "
              f"max {gap.max():.3f} cm")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--num", type=int, default=4000, help="transitions of the parallel run")
    parser.add_argument("--workers", type=int, default=2, help="worker processes")
    parser.add_argument("--seed", type=int, default=0, help="collection seed")
    parser.add_argument("--single", type=int, default=400,
                        help="transitions of the single-process chunk")
    parser.add_argument("--iterations", type=int, nargs="+", default=[],
                        help="solver iterations per physics step to compare with the cord's "
                             "by replaying moves (other physics; none by default)")
    parser.add_argument("--replay", type=int, default=200,
                        help="moves replayed for --iterations")
    args = parser.parse_args()
    for name in ("num", "workers", "single", "replay"):
        if getattr(args, name) < 1:
            parser.error(f"--{name} must be >= 1, got {getattr(args, name)}")
    if any(k < 1 for k in args.iterations):
        parser.error(f"--iterations must all be >= 1, got {args.iterations}")
    config = TransitionCollectConfig(seed=args.seed)
    print(f"load average at start: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    chunk, one = single_process(config, args.single)
    if args.iterations:
        solver_tradeoff(config, chunk.subset(np.arange(len(chunk)) < args.replay),
                        args.iterations)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        data = collect_transitions(os.path.join(tmp, "bench.npz"), args.num, config,
                                   workers=args.workers)
        wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    rate = len(data) / wall
    print(f"{args.workers} workers : {rate:6.1f} transitions/s ({len(data)} in {wall:.1f} s wall, "
          f"start-up and final file included; {rate / one:.2f}x one process)")
    if cpu > 0:
        print(f"the workers got {cpu:.1f} CPU-s in {wall:.1f} s ({cpu / wall:.2f} of "
              f"{args.workers} cores) -> {len(data) / cpu:.1f} transitions per CPU-second")
    verdict = "PASS" if rate >= RATE_FLOOR else "FAIL"
    print(f"floor transitions/s >= {RATE_FLOOR:.0f} with {args.workers} workers: {rate:.1f}  "
          f"{verdict}")


if __name__ == "__main__":  # worker processes are spawned and import this module
    main()
