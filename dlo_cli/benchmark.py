"""``dlo benchmark``: every agent on the test suites of both environments, one table."""

from __future__ import annotations

import argparse

from dlo_cli.flags import (
    add_agent,
    add_backend,
    add_difficulty,
    add_model,
    add_out,
    add_planner_flags,
    backend_of,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo benchmark``; defaults are ``BenchmarkConfig``'s (the published table)."""
    from dlo_bench.benchmark import QUICK_EPISODES, BenchmarkConfig

    parser.add_argument("--quick", action="store_true",
                        help=f"{QUICK_EPISODES} episodes of each cell: a smoke test of every "
                             "agent (about 2 minutes on two cores)")
    parser.add_argument("--episodes", type=int, default=None,
                        help="episodes per agent and difficulty, the first tasks of each test "
                             f"split (None: {BenchmarkConfig.episodes}, the whole split; "
                             f"{QUICK_EPISODES} with --quick)")
    from dlo_bench.benchmark import DEFAULT_DIFFICULTIES
    from dlo_env.envs import ENVIRONMENTS

    add_agent(parser, default=list(BenchmarkConfig.agents))
    parser.add_argument("--env", nargs="+", default=list(BenchmarkConfig.envs),
                        choices=list(ENVIRONMENTS), metavar="ENV_ID",
                        help="environments, one or several: " + ", ".join(ENVIRONMENTS))
    defaults = "; ".join(f"{e.split('/')[-1]}: {' '.join(map(str, d))}"
                         for e, d in DEFAULT_DIFFICULTIES.items())
    add_difficulty(parser, None, "each runs the test split of suite linear-K in every "
                                 f"--env (None: {defaults})")
    parser.add_argument("--baselines", default=BenchmarkConfig.baselines,
                        help="folder with one `dlo baseline` output folder per RL agent and "
                             "environment (BASELINES/ppo, BASELINES/sac-her, BASELINES/bc; "
                             "BASELINES/ppo-dual-endpoint... for DLODualEndpoint-v0; None: the "
                             "shipped ones)")
    add_model(parser)
    parser.add_argument("--transition-model", default=None,
                        help="transition model file, or folder holding transition.pt, for "
                             "latent-mpc and latent-tree-kino (None: the shipped "
                             "latent_model/pretrained/transition.pt)")
    add_planner_flags(parser)
    parser.add_argument("--seed", type=int, default=BenchmarkConfig.seed,
                        help="seed of the planners' sampling (the tasks are the suites')")
    add_backend(parser, "this process, one cell after the other")
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
    from dlo_bench.benchmark_report import ratio_lines, write_results

    torch.set_num_threads(args.threads)
    episodes = args.episodes if args.episodes is not None else (
        QUICK_EPISODES if args.quick else BenchmarkConfig.episodes)
    config = BenchmarkConfig(
        agents=tuple(args.agent), envs=tuple(args.env),
        difficulties=tuple(args.difficulty) if args.difficulty else None, episodes=episodes,
        seed=args.seed, baselines=args.baselines, model=args.model,
        transition_model=args.transition_model,
        replan_every=args.replan_every, max_seconds=args.max_seconds,
        fidelity=not args.no_fidelity,
    )
    cells = ", ".join(f"{e.split('/')[-1]} d{d}" for e, d in config.cells())
    print(f"benchmark: {len(config.agents)} agents x ({cells}) x {config.episodes} episodes "
          f"-> {args.out}", flush=True)
    t0 = time.perf_counter()
    rows = run_benchmark(config, args.out, resume=args.resume, progress=True,
                         backend=backend_of(args))
    seconds = time.perf_counter() - t0
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    paths = write_results(rows, args.out, _command(args, vars(parser.parse_args([]))), seconds)
    from dlo_bench.benchmark_report import success_table

    print("\n".join(success_table(rows)))
    print("\n".join(ratio_lines(rows)) or "planning time ratios not measured: physics-mpc did "
                                          "not run with a cheaper planner")
    missing = sorted({r["agent"] for r in rows if r["status"] != "ok"})
    if missing:
        print("agents with missing cells (reported in the table): " + ", ".join(missing))
    print(f"wrote {paths['md']}, {paths['json']}, {paths['png']} in {seconds:.0f} s")
    return 0
