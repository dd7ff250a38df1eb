"""``dlo benchmark``: every agent on the test suites of difficulty 1-3, one table."""

from __future__ import annotations

import argparse

from dlo_cli.flags import add_agent, add_difficulty, add_model, add_out, add_planner_flags


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo benchmark``; defaults are ``BenchmarkConfig``'s (the published table)."""
    from dlo_bench.benchmark import QUICK_EPISODES, BenchmarkConfig

    parser.add_argument("--quick", action="store_true",
                        help=f"{QUICK_EPISODES} episodes of each cell: a smoke test of every "
                             "agent (under a minute on two cores; CI runs it)")
    parser.add_argument("--episodes", type=int, default=None,
                        help="episodes per agent and difficulty, the first tasks of each test "
                             f"split (None: {BenchmarkConfig.episodes}, the whole split; "
                             f"{QUICK_EPISODES} with --quick)")
    add_agent(parser, default=list(BenchmarkConfig.agents))
    add_difficulty(parser, list(BenchmarkConfig.difficulties),
                   "each runs the test split of suite linear-K")
    parser.add_argument("--baselines", default=BenchmarkConfig.baselines,
                        help="folder with one `dlo baseline` output folder per RL agent "
                             "(BASELINES/ppo, BASELINES/sac-her; None: the shipped ones)")
    add_model(parser)
    add_planner_flags(parser)
    parser.add_argument("--seed", type=int, default=BenchmarkConfig.seed,
                        help="seed of the planners' sampling (the tasks are the suites')")
    parser.add_argument("--resume", action="store_true",
                        help="reuse the cells an interrupted run with the same settings wrote")
    add_out(parser, "benchmark", "results.md/.json/.png and results_episodes/; "
                                 "`--out benchmarks` refreshes the committed results")


def _command(args: argparse.Namespace, parser_defaults: dict) -> str:
    """The command line that reproduces this run (flags that differ from the defaults)."""
    parts = ["dlo benchmark"]
    for key, value in vars(args).items():
        if key.startswith("_") or key in ("command", "debug") or value == parser_defaults.get(key):
            continue
        flag = "--" + key.replace("_", "-")
        if value is True:
            parts.append(flag)
        elif isinstance(value, list):
            parts.append(f"{flag} {' '.join(map(str, value))}")
        else:
            parts.append(f"{flag} {value}")
    return " ".join(parts)


def run(args: argparse.Namespace) -> int:
    """Run the benchmark, print the table and the speed ratio, write the results."""
    import time

    import torch

    from dlo_bench.benchmark import QUICK_EPISODES, BenchmarkConfig, run_benchmark
    from dlo_bench.benchmark_report import planning_time_ratios, write_results

    torch.set_num_threads(args.threads)
    episodes = args.episodes if args.episodes is not None else (
        QUICK_EPISODES if args.quick else BenchmarkConfig.episodes)
    config = BenchmarkConfig(
        agents=tuple(args.agent), difficulties=tuple(args.difficulty), episodes=episodes,
        seed=args.seed, baselines=args.baselines, model=args.model,
        replan_every=args.replan_every, max_seconds=args.max_seconds,
        fidelity=not args.no_fidelity,
    )
    print(f"benchmark: {len(config.agents)} agents x difficulties {config.difficulties} x "
          f"{config.episodes} episodes -> {args.out}", flush=True)
    t0 = time.perf_counter()
    rows = run_benchmark(config, args.out, resume=args.resume, progress=True)
    seconds = time.perf_counter() - t0
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    paths = write_results(rows, args.out, _command(args, vars(parser.parse_args([]))), seconds)
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
