"""Tune latent-mpc's budget on the train splits (never on test tasks).

Every configuration of a small grid runs on the first ``--episodes`` train tasks of each suite
(``DLOEndpoint-v0``, and ``DLODualEndpoint-v0`` with ``--dual``), on one torch thread, with the
shipped transition model. For each it prints and writes (``runs/tune-latent-mpc/sweep.csv``,
resumable: finished rows are kept) the success rate, median final error and mean planning
seconds per episode. The chosen values become ``LatentMPCConfig``'s defaults by hand, with the
sweep quoted in ``docs/history.md``.

    python benchmarks/tune_latent_mpc.py --episodes 40
    python benchmarks/tune_latent_mpc.py --grid '{"inextensible": [false, true]}' \
        --suite linear-3 linear-4 linear-5 --out runs/tune-inextensible

``--grid`` replaces the grid (any ``LatentMPCConfig`` fields; the others keep their defaults,
elites a tenth of the samples when samples are swept); ``--model`` tunes for another
transition model file.
"""

from __future__ import annotations

import argparse
import csv
import itertools
import json
import time
from pathlib import Path

import numpy as np

#: The grid: every combination of these ``LatentMPCConfig`` fields is run.
GRID = {
    "members": (1, 5),
    "samples": (64, 256),
    "iterations": (3, 5),
    "moves": (2, 3),
    "stop_fraction": (0.0, 0.5),
}
SUITES = ("linear-1", "linear-2", "linear-3", "linear-4", "linear-5")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=40,
                        help="first train tasks of each suite per configuration")
    parser.add_argument("--suite", nargs="+", default=list(SUITES),
                        help="suites whose train splits are run")
    parser.add_argument("--dual", action="store_true",
                        help="run DLODualEndpoint-v0 instead of DLOEndpoint-v0")
    parser.add_argument("--out", default="runs/tune-latent-mpc",
                        help="output folder (sweep.csv)")
    parser.add_argument("--grid", default=None,
                        help="JSON object of LatentMPCConfig fields to lists of values, in place "
                             "of the built-in grid")
    parser.add_argument("--model", default=None,
                        help="transition model file (default: the shipped one)")
    args = parser.parse_args()
    grid = GRID
    if args.grid is not None:
        try:
            grid = {k: tuple(v) for k, v in json.loads(args.grid).items()}
        except (ValueError, TypeError, AttributeError) as exc:
            raise SystemExit(f"--grid must be a JSON object of field names to lists, got "
                             f"{args.grid!r} ({exc})") from None

    import gymnasium as gym
    import torch

    import dlo_env  # noqa: F401  (registers the environments)
    from dlo_bench.evaluation import evaluate
    from dlo_env.atomic import write_text_atomic
    from latent_model import TransitionModel
    from planners.latent_mpc import LatentMPCConfig, LatentMPCPolicy

    torch.set_num_threads(1)
    env_id = "dlo_env/DLODualEndpoint-v0" if args.dual else "dlo_env/DLOEndpoint-v0"
    model = TransitionModel.load_or_pretrained(args.model, device="cpu")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / ("sweep-dual.csv" if args.dual else "sweep.csv")
    keys = list(grid)
    columns = [*keys, "suite", "episodes", "success", "median_error_cm", "seconds_per_episode"]
    done = list(csv.DictReader(path.open())) if path.is_file() else []
    seen = {tuple(r[k] for k in [*keys, "suite", "episodes"]) for r in done}
    rows = list(done)
    for values in itertools.product(*grid.values()):
        setting = dict(zip(keys, values))
        if "samples" in setting and "elites" not in setting:
            setting_kw = {**setting, "elites": max(2, setting["samples"] // 10)}
        else:
            setting_kw = setting
        config = LatentMPCConfig(**setting_kw)
        for suite in args.suite:
            tag = tuple(str(setting[k]) for k in keys) + (suite, str(args.episodes))
            if tag in seen:
                continue
            policy = LatentMPCPolicy.for_env(gym.make(env_id), config, model=model)
            t0 = time.perf_counter()
            result = evaluate(policy, env_id, suite=suite, episodes=args.episodes, split="train",
                              agent="latent-mpc", fidelity=False)
            seconds = [r.planning_seconds for r in result.records]
            row = {**setting, "suite": suite, "episodes": args.episodes,
                   "success": f"{result.summary['success_rate']:.3f}",
                   "median_error_cm": f"{100 * result.summary['median_final_error']:.2f}",
                   "seconds_per_episode": f"{np.mean(seconds):.4f}"}
            rows.append(row)
            lines = [",".join(columns)] + [",".join(str(r[c]) for c in columns) for r in rows]
            write_text_atomic(path, "\n".join(lines) + "\n")
            print(" ".join(f"{k}={v}" for k, v in row.items()),
                  f"({time.perf_counter() - t0:.0f} s)", flush=True)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
