"""Tune a planner's budget (latent-mpc, grad-mpc or physics-mpc) on the train splits, per threshold.

Every configuration of a grid runs on the first ``--episodes`` train tasks of each suite, at
each success threshold (judged at rest, the planner's stopping rule taken from it), on one
torch thread per process (designed suites such as ``shapes-curves`` in their environment:
200-step episodes scored direction-free). For each it prints and writes
(``OUT/sweep-AGENT-ENV.csv``, resumable: a finished row is reused only for the same full
config, model file and planner code) the success rate, the median error at rest and the mean
planning seconds per episode. The chosen values become
the planner's defaults by hand (``LatentMPCConfig``, ``PhysicsMPCConfig``: one setting for
every threshold), with the sweep quoted in ``docs/history.md``. Test splits are never run.

    python benchmarks/tune_planner.py --agent latent-mpc --episodes 40
    python benchmarks/tune_planner.py --agent physics-mpc --threshold 0.01 0.005 \\
        --grid '{"replan_every": [8, null], "samples": [32, 64]}' --jobs 2

``--grid`` is a JSON object of config fields to lists of values (``null`` is None; the other
fields keep their defaults, elites a tenth of the samples when samples are swept);
latent-mpc and grad-mpc plan on the model the benchmark gives them in each suite (the one
fine-tuned for a designed suite's cord, the one that sees pegs among pegs), or on ``--model``
in every suite; ``--jobs`` runs
that many (configuration, suite, threshold) cells at once in worker processes.
"""

from __future__ import annotations

import argparse
import csv
import io
import itertools
import json
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import numpy as np

#: The default grid of each agent (every combination runs).
GRIDS = {
    "latent-mpc": {"members": (1, 5), "samples": (64, 256), "iterations": (3, 5),
                   "moves": (2, 3), "stop_fraction": (0.0, 0.5)},
    "grad-mpc": {"samples": (4, 16), "grad_steps": (10, 40)},
    "physics-mpc": {"replan_every": (8, None), "samples": (32, 64), "moves": (2, 3)},
}
SUITES = ("linear-1", "linear-2", "linear-3", "linear-4", "linear-5")
ENVS = {"endpoint": "dlo_env/DLOEndpoint-v0", "dual": "dlo_env/DLODualEndpoint-v0"}


def _config(agent: str, setting: dict[str, Any]) -> Any:
    from planners.grad_mpc import GradMPCConfig
    from planners.latent_mpc import LatentMPCConfig
    from planners.physics_mpc import PhysicsMPCConfig

    kind = {"latent-mpc": LatentMPCConfig, "grad-mpc": GradMPCConfig}.get(agent,
                                                                         PhysicsMPCConfig)
    setting = {k: tuple(v) if isinstance(v, list) else v for k, v in setting.items()}  # JSON
    if "samples" in setting and "elites" not in setting:
        setting = {**setting, "elites": max(2, setting["samples"] // 10)}
    return kind(**setting)


#: The packages whose source a row's numbers depend on (its ``code`` digest).
CODE_PACKAGES = ("dlo_env", "latent_model", "planners", "dlo_bench")


def code_digest() -> str:
    """The first 16 hex digits of the SHA-256 of the source of ``CODE_PACKAGES``: the same
    for the same code, committed or not, and unchanged by commits elsewhere (docs, results)."""
    import hashlib

    root = Path(__file__).resolve().parent.parent
    digest = hashlib.sha256()
    for package in CODE_PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()[:16]


def fingerprint(agent: str, setting: dict[str, Any], model: str, code: str) -> dict[str, str]:
    """What a row's numbers depend on besides its suite, threshold and episodes: the full
    config (every field, not only the grid's), the model file's digest (``model``) and the
    source's (``code``); a row is reused only when all three match."""
    return {"config": repr(_config(agent, setting)), "model": model, "code": code}


def suite_model_digest(agent: str, env_id: str, suite: str, model: str | None) -> str:
    """The digest of the transition model file ``agent`` plans on in ``suite``'s environment
    (``model``, or the shipped one for the suite's cord or pegs); "" for physics-mpc."""
    import gymnasium as gym

    import dlo_env  # noqa: F401  (registers the environments)
    from dlo_bench.agents import model_files
    from dlo_bench.evaluation import task_env_kwargs
    from dlo_env.core.atomic import file_digest

    if agent not in ("latent-mpc", "grad-mpc"):
        return ""
    env = gym.make(env_id, **task_env_kwargs(suite=suite))
    try:
        return "+".join(file_digest(f) for f in model_files(agent, env, transition_model=model))
    finally:
        env.close()


def run_cell(agent: str, env_id: str, setting: dict[str, Any], suite: str, threshold: float,
             episodes: int, model: str | None, prints: dict[str, str]) -> dict[str, Any]:
    """One (configuration, suite, threshold) on the train split: its row of the sweep
    (``prints``: its :func:`fingerprint`, taken once when the sweep starts)."""
    import gymnasium as gym
    import torch

    import dlo_env  # noqa: F401  (registers the environments)
    from dlo_bench.evaluation import evaluate, task_env_kwargs

    torch.set_num_threads(1)
    kwargs = {**task_env_kwargs(suite=suite), "success_threshold": threshold}
    env = gym.make(env_id, **kwargs)  # the suite's environment (designed: direction-free)
    config = _config(agent, setting)
    if agent in ("latent-mpc", "grad-mpc"):
        from dlo_bench.agents import AgentOptions, planner_model
        from planners.grad_mpc import GradMPCPolicy
        from planners.latent_mpc import LatentMPCPolicy

        kind = LatentMPCPolicy if agent == "latent-mpc" else GradMPCPolicy
        # the model the benchmark's agent plans on there (the suite's cord, the pegs it sees)
        policy = kind.for_env(env, config, model=planner_model(
            agent, env, AgentOptions(transition_model=model)))
    else:
        from planners.physics_mpc import PhysicsMPCPolicy

        policy = PhysicsMPCPolicy.for_env(env, config)
    t0 = time.perf_counter()
    result = evaluate(policy, env_id, suite=suite, episodes=episodes, split="train",
                      agent=agent, fidelity=False, env_kwargs=kwargs)
    s = result.summary
    rest = s["median_rest_direction_free_error" if "success_metric" in kwargs else
             "median_rest_error"]
    return {**{k: json.dumps(v) for k, v in setting.items()}, "suite": suite,
            "threshold": threshold, "episodes": episodes,
            **prints,
            "success": f"{s['success_rate']:.3f}",
            "median_rest_error_cm": f"{100 * rest:.2f}",
            "seconds_per_episode": f"{np.mean([r.planning_seconds for r in result.records]):.4f}",
            "wall_seconds": f"{time.perf_counter() - t0:.0f}"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--agent", choices=list(GRIDS), default="latent-mpc")
    parser.add_argument("--env", choices=list(ENVS), default="endpoint")
    parser.add_argument("--episodes", type=int, default=40,
                        help="first train tasks of each suite per configuration")
    parser.add_argument("--suite", nargs="+", default=list(SUITES),
                        help="suites whose train splits are run")
    parser.add_argument("--threshold", nargs="+", type=float, default=[0.02],
                        help="success thresholds, metres")
    parser.add_argument("--grid", default=None,
                        help="JSON object of config fields to lists of values")
    parser.add_argument("--model", default=None,
                        help="latent-mpc's or grad-mpc's transition model file (default: the "
                             "shipped one the benchmark plans with in each suite)")
    parser.add_argument("--jobs", type=int, default=1, help="worker processes")
    parser.add_argument("--out", default="runs/tune-planner", help="output folder")
    args = parser.parse_args()
    grid = GRIDS[args.agent]
    if args.grid is not None:
        try:
            grid = {k: tuple(v) for k, v in json.loads(args.grid).items()}
            _config(args.agent, {k: v[0] for k, v in grid.items()})
        except (ValueError, TypeError, AttributeError) as exc:
            raise SystemExit(f"--grid must be a JSON object of {args.agent} config fields to "
                             f"lists, got {args.grid!r} ({exc})") from None

    from dlo_env.core.atomic import write_text_atomic

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"sweep-{args.agent}-{args.env}.csv"
    keys = list(grid)
    ident = ["suite", "threshold", "episodes", "config", "model", "code"]  # what a reuse needs
    columns = [*keys, *ident, "success", "median_rest_error_cm", "seconds_per_episode",
               "wall_seconds"]
    rows, old_columns = [], []
    if path.is_file():
        with path.open(newline="") as f:
            reader = csv.DictReader(f)
            rows, old_columns = list(reader), list(reader.fieldnames or ())
    columns = [*(c for c in old_columns if c not in columns), *columns]  # keep old rows whole
    seen = {tuple(r.get(k, "") for k in ident) for r in rows}
    todo, reused = [], 0
    models = {suite: suite_model_digest(args.agent, ENVS[args.env], suite, args.model)
              for suite in args.suite}
    code = code_digest()
    for values in itertools.product(*grid.values()):
        setting = dict(zip(keys, values))
        for threshold in args.threshold:
            for suite in args.suite:
                prints = fingerprint(args.agent, setting, models[suite], code)
                tag = (suite, str(threshold), str(args.episodes), *prints.values())
                if tag in seen:
                    reused += 1
                else:
                    todo.append((args.agent, ENVS[args.env], setting, suite, threshold,
                                 args.episodes, args.model, prints))
    print(f"{len(todo)} cells to run, {reused} reused (rows of another config, model or code "
          f"are kept, not reused) -> {path}", flush=True)
    with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = [pool.submit(run_cell, *cell) for cell in todo]
        for future in as_completed(futures):
            row = future.result()
            rows.append(row)
            text = io.StringIO()  # csv quotes the fields with commas (configs, JSON lists)
            writer = csv.DictWriter(text, columns, extrasaction="ignore", lineterminator="\n")
            writer.writeheader()
            writer.writerows(rows)
            write_text_atomic(path, text.getvalue())
            print(" ".join(f"{k}={v}" for k, v in row.items() if k != "config"), flush=True)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
