"""Dataset collection throughput and diversity: accepted shapes/s, grid coverage, distinct shapes.

Floors (issue 3): at least 2000 accepted shapes/s with 2 worker processes; cord points on at
least 60 % of a 10 x 10 grid over the table; at least 90 % of the shapes distinct at 1 cm.
Every number is measured in this run:

1. one chunk in this process, with ``pymunk.Space.step`` timed, gives the single-process rate
   and the share of its time spent in physics (the rest is recording, filtering, bookkeeping);
2. ``collect`` with ``--workers`` processes writes a dataset to a temporary folder; its wall
   time (process start-up and the final file included) gives the parallel rate;
3. the diversity measures of ``dlo_env.dataset.diversity`` (the ones ``dlo collect``
   prints) are taken on that dataset.

The machine is shared: the load average at the start is printed, since other processes on the
two cores lower the parallel rate. To separate the code's speed from the machine's load, the
CPU time the worker processes actually got is measured too (``getrusage`` of the children):
accepted shapes per worker CPU-second is the rate of one worker that has a core to itself, and
``workers`` times it is what the run would reach on that many free cores (an estimate, printed
as such, not the floor's measurement).

Usage::

    python benchmarks/collect_throughput.py [--num-shapes 40000] [--workers 2] [--seed 0]
"""

from __future__ import annotations

import argparse
import os
import resource
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import pymunk

from dlo_env.dataset.collect import CollectConfig, collect, collect_chunk
from dlo_env.dataset.diversity import diversity_report

RATE_FLOOR = 2000.0
COVERAGE_FLOOR = 0.60
DISTINCT_FLOOR = 0.90


@dataclass(frozen=True)
class Args:
    """Benchmark settings."""

    num_shapes: int = 40000
    workers: int = 2
    seed: int = 0
    single_shapes: int = 4000


@contextmanager
def physics_timer() -> Iterator[list[float]]:
    """Time spent in pymunk's ``Space.step`` while the block runs, and the steps taken:
    ``[seconds, steps]``."""
    original = pymunk.Space.step
    spent = [0.0, 0]

    def timed(space: pymunk.Space, dt: float) -> None:
        t = time.perf_counter()
        original(space, dt)
        spent[0] += time.perf_counter() - t
        spent[1] += 1

    pymunk.Space.step = timed
    try:
        yield spent
    finally:
        pymunk.Space.step = original


def single_process(config: CollectConfig, shapes: int) -> tuple[float, float]:
    """Accepted shapes/s of one chunk in this process, and the share of time in physics."""
    collect_chunk(config, 10_000, 50)  # warm-up
    with physics_timer() as spent:
        t = time.perf_counter()
        data = collect_chunk(config, 10_001, shapes)
        total = time.perf_counter() - t
    return data.num_shapes / total, spent[0] / total


def verdict(ok: bool) -> str:
    """PASS or FAIL."""
    return "PASS" if ok else "FAIL"


def main(args: Args) -> None:
    """Run the benchmark and print the measurements against the floors."""
    config = CollectConfig(seed=args.seed)
    print(f"load average at start: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    one_rate, physics_share = single_process(config, args.single_shapes)
    print(f"1 process : {one_rate:7.0f} accepted shapes/s "
          f"({physics_share:.0%} of the time in pymunk Space.step)")
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        data = collect(os.path.join(tmp, "bench.npz"), args.num_shapes, config,
                       workers=args.workers)
        wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    worker_cpu = (after.ru_utime - children.ru_utime) + (after.ru_stime - children.ru_stime)
    rate = data.num_shapes / wall
    meta = data.metadata
    seen = meta["accepted"] + meta["rejected"]["total"]
    print(f"{args.workers} workers : {rate:7.0f} accepted shapes/s "
          f"({data.num_shapes} shapes in {wall:.1f} s wall, start-up and final file included; "
          f"{rate / one_rate:.2f}x one process)")
    if args.workers > 1 and worker_cpu > 0:
        per_cpu = data.num_shapes / worker_cpu
        print(f"per worker: {rate / args.workers:7.0f} accepted shapes/s of wall time; the workers "
              f"got {worker_cpu:.1f} CPU-s in {wall:.1f} s ({worker_cpu / wall:.2f} of "
              f"{args.workers} cores)")
        print(f"per CPU-s : {per_cpu:7.0f} accepted shapes per worker CPU-second "
              f"(start-up included) -> estimate on {args.workers} free cores: "
              f"{args.workers * per_cpu:.0f}/s")
    print(f"rejected  : {meta['rejected']['total'] / max(seen, 1):.2%} "
          f"({meta['rejected']['cosine']} not cord-like, {meta['rejected']['stretch']} stretched)")
    report = diversity_report(data.shapes)
    for line in report.lines():
        print(line)
    print()
    print(f"floor accepted shapes/s >= {RATE_FLOOR:.0f} with {args.workers} workers: "
          f"{rate:.0f}  {verdict(rate >= RATE_FLOOR)}")
    print(f"floor grid coverage >= {COVERAGE_FLOOR:.0%}: {report.grid_coverage:.0%}  "
          f"{verdict(report.grid_coverage >= COVERAGE_FLOOR)}")
    print(f"floor distinct at 1 cm >= {DISTINCT_FLOOR:.0%}: {report.distinct_fraction:.1%}  "
          f"{verdict(report.distinct_fraction >= DISTINCT_FLOOR)}")


def parse() -> Args:
    """Benchmark settings from the command line."""
    d = Args()
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--num-shapes", type=int, default=d.num_shapes)
    parser.add_argument("--workers", type=int, default=d.workers)
    parser.add_argument("--seed", type=int, default=d.seed)
    ns = parser.parse_args()
    return Args(num_shapes=ns.num_shapes, workers=ns.workers, seed=ns.seed)


if __name__ == "__main__":  # worker processes are spawned and import this module
    main(parse())
