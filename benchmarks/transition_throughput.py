"""Transition collection speed: transitions per second in one process and with workers.

Prints the load average first (other jobs on the cores slow the workers down), one process's
rate and its share of time in pymunk, then a full ``collect_transitions`` run with ``--workers``
processes (start-up and the final file included), the CPU time the workers got, and the floor
(at least 150 transitions/s with 2 workers on a quiet machine).

    python benchmarks/transition_throughput.py [--num 4000] [--workers 2] [--seed 0]
"""

from __future__ import annotations

import argparse
import os
import resource
import tempfile
import time

from collect_throughput import physics_timer  # the script beside this one

from dlo_env.dataset.transitions import (
    TransitionCollectConfig,
    collect_transition_chunk,
    collect_transitions,
)

RATE_FLOOR = 150.0


def single_process(config: TransitionCollectConfig, count: int) -> tuple[float, float]:
    """Transitions/s of one chunk in this process, and the share of time in physics."""
    collect_transition_chunk(config, 10_000, 10)  # warm-up
    with physics_timer() as spent:
        t = time.perf_counter()
        data = collect_transition_chunk(config, 10_001, count)
        total = time.perf_counter() - t
    return len(data) / total, spent[0] / total


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--num", type=int, default=4000, help="transitions of the parallel run")
    parser.add_argument("--workers", type=int, default=2, help="worker processes")
    parser.add_argument("--seed", type=int, default=0, help="collection seed")
    args = parser.parse_args()
    config = TransitionCollectConfig(seed=args.seed)
    print(f"load average at start: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    one, physics = single_process(config, 400)
    print(f"1 process : {one:6.1f} transitions/s ({physics:.0%} of the time in pymunk Space.step)")
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
