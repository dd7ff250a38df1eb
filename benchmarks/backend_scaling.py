"""Collection throughput against the number of workers, local process pool and Ray.

For each worker count (1 .. ``--max-workers``) and each backend, collects ``--shapes`` shapes and
``--transitions`` transitions into a temporary folder and prints items per second of wall time
(start-up of the workers, or of the local Ray runtime, included: that is what a user waits for)
and the speed-up over one local worker. The arrays are the same on every backend (tested in
``tests/dlo_env/test_ray_backend.py``); only the time differs. The machine's load average is
printed: other processes on its cores lower every parallel rate.

Usage::

    python benchmarks/backend_scaling.py [--max-workers 2] [--shapes 20000] [--transitions 2000]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from dataclasses import dataclass

from dlo_env.core.ray_backend import RayBackend
from dlo_env.dataset.collect import CollectConfig, collect
from dlo_env.dataset.transitions import TransitionCollectConfig, collect_transitions


@dataclass(frozen=True)
class Args:
    """Arguments of the script."""

    max_workers: int = 2
    shapes: int = 20_000
    transitions: int = 2_000
    seed: int = 0


def rate(kind: str, backend: str, workers: int, args: Args) -> float:
    """Items per second of one collection run."""
    engine = RayBackend(num_cpus=workers) if backend == "ray" else None
    with tempfile.TemporaryDirectory() as folder:
        out = os.path.join(folder, "out.npz")
        started = time.perf_counter()
        if kind == "shapes":
            collect(out, args.shapes, CollectConfig(seed=args.seed), workers=workers,
                    backend=engine)
            items = args.shapes
        else:
            collect_transitions(out, args.transitions,
                                TransitionCollectConfig(seed=args.seed, chunk_size=100),
                                workers=workers, backend=engine)
            items = args.transitions
        return items / (time.perf_counter() - started)


def main(args: Args) -> None:
    """Print the table."""
    print(f"load average at start: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    print("| kind | backend | workers | items/s | speed-up over 1 local worker |")
    print("|---|---|---|---|---|")
    for kind in ("shapes", "transitions"):
        base = None
        for backend in ("local", "ray"):
            for workers in range(1, args.max_workers + 1):
                r = rate(kind, backend, workers, args)
                base = base or r
                print(f"| {kind} | {backend} | {workers} | {r:.0f} | {r / base:.2f} |",
                      flush=True)


def parse() -> Args:
    """Arguments from the command line."""
    d = Args()
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-workers", type=int, default=d.max_workers,
                        help="largest number of workers tried")
    parser.add_argument("--shapes", type=int, default=d.shapes, help="shapes per run")
    parser.add_argument("--transitions", type=int, default=d.transitions,
                        help="transitions per run")
    parser.add_argument("--seed", type=int, default=d.seed, help="root seed")
    ns = parser.parse_args()
    return Args(ns.max_workers, ns.shapes, ns.transitions, ns.seed)


if __name__ == "__main__":
    main(parse())
