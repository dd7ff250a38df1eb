"""``dlo benchmark``: every agent on the test suites of difficulty 1-3, one table."""

from __future__ import annotations

import argparse

AGENTS = ("straight-line", "latent-tree", "latent-tree-closed", "physics-mpc", "ppo", "sac-her")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo benchmark`` (they map onto ``planners.benchmark.BenchmarkConfig``)."""
    parser.add_argument("--episodes", type=int, default=None,
                        help="episodes per agent and difficulty, the first tasks of each test "
                             "split (default 50, the whole split; 2 with --quick)")
    parser.add_argument("--quick", action="store_true",
                        help="a few episodes of each (a couple of minutes; used by CI)")
    parser.add_argument("--agents", nargs="+", default=list(AGENTS), metavar="AGENT",
                        help=f"agents to run (default all: {' '.join(AGENTS)})")
    parser.add_argument("--difficulty", type=int, nargs="+", default=[1, 2, 3], metavar="K",
                        help="difficulties, each the test split of suite linear-K "
                             "(default 1 2 3)")
    parser.add_argument("--models", default="benchmarks/models",
                        help="folder with the RL baselines, one `dlo baseline` output folder "
                             "per agent: MODELS/ppo, MODELS/sac-her (default benchmarks/models)")
    parser.add_argument("--shape-model", default=None,
                        help="shape model file of the latent-tree agents (default: the shipped "
                             "latent_model/pretrained/model.pt)")
    parser.add_argument("--replan-every", type=int, default=10,
                        help="steps between replans of latent-tree-closed (default 10)")
    parser.add_argument("--max-seconds", type=float, default=None,
                        help="time budget of one latent-tree plan, seconds (default: the "
                             "planner's)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the planners (default 0)")
    parser.add_argument("--threads", type=int, default=1, help="torch CPU threads (default 1)")
    parser.add_argument("--no-fidelity", action="store_true",
                        help="skip the transition fidelity of the latent-tree plans")
    parser.add_argument("--resume", action="store_true",
                        help="reuse the cells an interrupted run with the same settings wrote")
    parser.add_argument("--out", default="benchmarks",
                        help="folder for results.md/.json/.png and results_episodes/ "
                             "(default benchmarks)")


def _command(args: argparse.Namespace) -> str:
    parts = ["dlo benchmark"]
    if args.quick:
        parts.append("--quick")
    if args.episodes is not None:
        parts.append(f"--episodes {args.episodes}")
    if list(args.agents) != list(AGENTS):
        parts.append("--agents " + " ".join(args.agents))
    if list(args.difficulty) != [1, 2, 3]:
        parts.append("--difficulty " + " ".join(map(str, args.difficulty)))
    for flag, value, default in (("--models", args.models, "benchmarks/models"),
                                 ("--shape-model", args.shape_model, None),
                                 ("--replan-every", args.replan_every, 10),
                                 ("--max-seconds", args.max_seconds, None),
                                 ("--seed", args.seed, 0), ("--threads", args.threads, 1),
                                 ("--out", args.out, "benchmarks")):
        if value != default:
            parts.append(f"{flag} {value}")
    if args.no_fidelity:
        parts.append("--no-fidelity")
    return " ".join(parts)


def run(args: argparse.Namespace) -> int:
    """Run the benchmark, print the table and the speed ratio, write the results."""
    import sys
    import time

    import torch

    from planners.benchmark import (
        QUICK_EPISODES,
        BenchmarkConfig,
        planning_time_ratios,
        run_benchmark,
        write_results,
    )

    torch.set_num_threads(max(1, args.threads))
    episodes = args.episodes if args.episodes is not None else (
        QUICK_EPISODES if args.quick else 50)
    try:
        config = BenchmarkConfig(
            agents=tuple(args.agents), difficulties=tuple(args.difficulty), episodes=episodes,
            seed=args.seed, models_dir=args.models, shape_model=args.shape_model,
            replan_every=args.replan_every, max_seconds=args.max_seconds,
            fidelity=not args.no_fidelity,
        )
    except ValueError as exc:
        print(f"dlo benchmark: {exc}", file=sys.stderr)
        return 2
    print(f"benchmark: {len(config.agents)} agents x difficulties {config.difficulties} x "
          f"{config.episodes} episodes -> {args.out}", flush=True)
    t0 = time.perf_counter()
    rows = run_benchmark(config, args.out, resume=args.resume, progress=True)
    seconds = time.perf_counter() - t0
    paths = write_results(rows, args.out, _command(args), seconds)
    print(paths["md"].read_text().split("\n\n", 2)[2].split("\n\n")[0])  # the table
    ratios = planning_time_ratios(rows)
    if ratios:
        print(f"planning time physics-mpc / latent-tree on the same {config.episodes} episodes "
              f"per difficulty: " + ", ".join(f"{k} {v:.1f}x" for k, v in ratios.items()))
    else:
        print("planning time ratio not measured: physics-mpc and latent-tree did not both run")
    missing = sorted({r["agent"] for r in rows if r["status"] != "ok"})
    if missing:
        print("missing agents (reported in the table): " + ", ".join(missing))
    print(f"wrote {paths['md']}, {paths['json']}, {paths['png']} in {seconds:.0f} s")
    return 0
