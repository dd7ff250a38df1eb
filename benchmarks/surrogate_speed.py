"""Surrogate vs simulator: time to produce shape transitions, and inversion time per shape.

A *transition* is what a planner needs from a model: the shapes along one straight endpoint
move (here 10 shapes). The surrogate decodes them from latents in one batch; the simulator
has to run the move. Both produce 1 000 transitions in one run and the ratio is printed
(floor: the surrogate is at least 100x faster). The surrogate's time is the median of a few
calls (the first, cold call is printed too); the simulator's is one pass over 1 000 moves.
Inversion (``ShapeModel.invert``: Encoder guess + batched refinement) is timed batched and one
shape at a time.

    python benchmarks/surrogate_speed.py [--model PATH] [--transitions 1000] \\
        [--repeats 5] [--threads 1]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
import torch

from dlo_env.cord import Cord
from dlo_env.shapes import random_cord_shape
from latent_model import ShapeModel


def surrogate_transitions(
    model: ShapeModel, count: int, length: int, seed: int, repeats: int
) -> tuple[float, float]:
    """Seconds to decode ``count`` transitions of ``length`` shapes (latent lines).

    Returns the first (cold) call, which pays for the allocator and the caches, and the median
    of ``repeats`` further calls on new latents (the steady state a planner sees).
    """
    times = []
    for r in range(repeats + 1):
        a = model.sample_latent(count, seed=seed + 2 * r)
        b = model.sample_latent(count, seed=seed + 2 * r + 1)
        t = np.linspace(0.0, 1.0, length, dtype=np.float32)[None, :, None]
        latents = (a[:, None] * (1 - t) + b[:, None] * t).reshape(-1, model.latent_dim)
        start = time.perf_counter()
        shapes = model.decode(latents).reshape(count, length, model.n_points, 2)
        times.append(time.perf_counter() - start)
        assert np.isfinite(shapes).all()
    return times[0], float(np.median(times[1:]))


def simulated_transitions(count: int, length: int, seed: int) -> float:
    """Seconds to simulate ``count`` straight head moves of 5-30 cm, recording ``length`` shapes."""
    rng = np.random.default_rng(seed)
    cord = Cord(grasp="head")
    starts = [random_cord_shape(rng) for _ in range(count)]
    moves = []
    for _ in range(count):
        angle, dist = rng.uniform(-np.pi, np.pi), rng.uniform(0.05, 0.30)
        moves.append(dist * np.array([np.cos(angle), np.sin(angle)]))
    start = time.perf_counter()
    for shape, move in zip(starts, moves):
        cord.reset(shape)
        periods = max(1, int(np.ceil(np.linalg.norm(move) / (cord.params.max_speed *
                                                             cord.params.dt))))
        every = max(1, periods * cord.params.substeps // length)
        recorded = cord.move(head=move, record_every=every)
        assert len(recorded) >= 1
    return time.perf_counter() - start


def inversion_seconds(model: ShapeModel, shapes: np.ndarray) -> tuple[float, float, float]:
    """Seconds per shape of batched and single inversion, and the batched success rate."""
    model.invert(shapes[:2])  # warm-up
    start = time.perf_counter()
    _, _, ok = model.invert(shapes)
    batched = (time.perf_counter() - start) / len(shapes)
    singles = shapes[:20]
    start = time.perf_counter()
    for s in singles:
        model.invert(s)
    single = (time.perf_counter() - start) / len(singles)
    return batched, single, float(ok.mean())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default=None, help="model.pt (default: the shipped model)")
    parser.add_argument("--transitions", type=int, default=1000)
    parser.add_argument("--length", type=int, default=10, help="shapes per transition")
    parser.add_argument("--inversions", type=int, default=500)
    parser.add_argument("--repeats", type=int, default=5, help="timed decode calls after the first")
    parser.add_argument("--threads", type=int, default=1, help="torch CPU threads")
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    load = os.getloadavg()[0]
    torch.set_num_threads(args.threads)
    model = ShapeModel.load_or_pretrained(args.model, device=args.device)
    n, k = args.transitions, args.length
    model.decode(model.sample_latent(16, seed=args.seed))  # import-time and first-call costs
    cold, t_model = surrogate_transitions(model, n, k, args.seed, args.repeats)
    t_sim = simulated_transitions(n, k, args.seed)
    ratio = t_sim / t_model
    print(f"load average at start: {load:.2f} on {os.cpu_count()} cores")
    print(f"{n} transitions of {k} shapes, torch threads {args.threads}, device {model.device}")
    print(f"  surrogate (decode):  {t_model:8.3f} s   {1e6 * t_model / n:9.1f} us/transition "
          f"(median of {args.repeats} calls; first call {cold:.3f} s, "
          f"{t_sim / cold:.0f}x)")
    print(f"  simulator (pymunk):  {t_sim:8.3f} s   {1e6 * t_sim / n:9.1f} us/transition")
    print(f"  surrogate speed-up:  {ratio:8.0f}x   (floor 100x: "
          f"{'PASS' if ratio >= 100 else 'FAIL'})")
    rng = np.random.default_rng(args.seed + 7)
    shapes = np.stack([random_cord_shape(rng) for _ in range(args.inversions)])
    batched, single, ok = inversion_seconds(model, shapes)
    print(f"inversion of {args.inversions} random cord shapes (Encoder + refinement, 4 starts)")
    print(f"  batched: {1e3 * batched:8.3f} ms/shape   single: {1e3 * single:8.1f} ms/shape   "
          f"represented within 1 cm: {ok:.3f}")


if __name__ == "__main__":
    main()
