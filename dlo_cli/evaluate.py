"""``dlo evaluate``: score agents on the cord environment, print a table, write CSV and JSON."""

from __future__ import annotations

import argparse

from dlo_cli.flags import (
    add_agent,
    add_difficulty,
    add_model,
    add_out,
    add_planner_flags,
    add_seed,
    positive_int,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo evaluate``."""
    from dlo_env.tasks import SUITES

    add_agent(parser, default=None)
    which = parser.add_mutually_exclusive_group()
    add_difficulty(which, [1], "random tasks (reset seeds SEED, SEED+1, ...); several give "
                               "several rows")
    which.add_argument("--suite", nargs="+", metavar="NAME",
                       help=f"named task suites instead of random tasks: {', '.join(SUITES)}")
    parser.add_argument("--split", default="test", choices=("test", "train"),
                        help="split of the suites")
    parser.add_argument("--episodes", type=positive_int, default=20, help="episodes per row")
    add_seed(parser, "the tasks (episode i of random tasks resets with SEED+i) and planners")
    parser.add_argument("--env-id", default="dlo_env/DLOEndpoint-v0", help="environment")
    add_model(parser)
    add_planner_flags(parser)
    add_out(parser, "evaluate", "<agent>-<difficulty>.csv/.json and summary.json")


def _file_name(agent: str, label: str) -> str:
    safe = "".join(c if c.isalnum() or c in "-_." else "-" for c in agent.replace("sb3:", "sb3-"))
    return f"{safe.strip('-')}-{label}"


def run(args: argparse.Namespace) -> int:
    """Evaluate every agent on every difficulty (or suite), print the table, write files."""
    import platform
    from pathlib import Path

    import gymnasium as gym

    import dlo_env  # noqa: F401  (registers the environments)
    from dlo_bench.agents import agent_spec, build_agent, load_shape_model
    from dlo_bench.evaluation import evaluate
    from dlo_bench.report import format_divergence, format_table, write_evaluation, write_summaries
    from dlo_env.tasks import suite_seeds

    specs = [agent_spec(agent) for agent in args.agent]  # unknown names fail before any work
    for suite in args.suite or []:
        suite_seeds(suite, args.split)
    model = None
    if any(spec.shape_model for spec in specs):
        import torch

        torch.set_num_threads(args.threads)
        model = load_shape_model(args.model)
    rows = ([(None, s, s) for s in args.suite] if args.suite
            else [(d, None, f"d{d}") for d in args.difficulty])
    out = Path(args.out)
    settings = {k: v for k, v in vars(args).items() if not k.startswith("_")}
    summaries = []
    for agent in args.agent:
        for difficulty, suite, label in rows:
            with gym.make(args.env_id) as env:
                policy = build_agent(agent, env, model=model, seed=args.seed,
                                     replan_every=args.replan_every,
                                     max_seconds=args.max_seconds)
            result = evaluate(policy, args.env_id, difficulty=difficulty, suite=suite,
                              episodes=args.episodes, seed=args.seed, split=args.split,
                              agent=agent, fidelity=not args.no_fidelity, progress=True)
            extra = {"arguments": settings, "machine": platform.platform()}
            write_evaluation(result, out, _file_name(agent, label), extra=extra)
            summaries.append(result.summary)
    print(format_table(summaries))
    parting = format_divergence(summaries)
    if parting:
        print("\nwhere plans and the real cord part ways: mean error (cm) of the first plan's "
              "shapes,\nby distance the end has travelled and by straight move")
        print(parting)
    write_summaries(summaries, out / "summary.json")
    print(f"wrote {len(summaries)} CSV and JSON files and summary.json to {out}")
    return 0
