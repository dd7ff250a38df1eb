"""``dlo evaluate``: score agents on the cord environment, print a table, write CSV and JSON."""

from __future__ import annotations

import argparse
from typing import Any

from dlo_cli.flags import (
    DEFAULT_EPISODES,
    add_agent,
    add_backend,
    add_difficulty,
    add_env,
    add_episodes,
    add_model,
    add_out,
    add_planner_flags,
    add_seed,
    add_transition_model,
    backend_of,
    existing_path,
    number_in,
    writable_folder,
)
from dlo_env.errors import InputError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo evaluate``."""
    from dlo_bench.benchmark import HEADLINE_THRESHOLD
    from dlo_bench.evaluation import suite_names
    from dlo_env.tasks import SPLIT_SIZES

    add_agent(parser, default=None)
    which = parser.add_mutually_exclusive_group()
    add_difficulty(which, [1], "random tasks (reset seeds SEED, SEED+1, ...); several give "
                               "several rows")
    suites = suite_names()
    which.add_argument("--suite", nargs="+", metavar="NAME", choices=suites,
                       help=f"named task suites instead of random tasks: {', '.join(suites)} "
                            "(designed goals are scored direction-free; cords-K tasks each "
                            "run on their own cord, not told to the agent; pegs-K and route-K "
                            "tasks have pegs on the table, route-K goals need the cord routed "
                            "around them)")
    parser.add_argument("--split", default="test", choices=tuple(SPLIT_SIZES),
                        help="split of the suites")
    add_episodes(parser, f"episodes per row (default {DEFAULT_EPISODES}: a quick look; a "
                         "suite's split has " + ", ".join(
                             f"{n} {split}" for split, n in SPLIT_SIZES.items()) + " tasks)")
    add_seed(parser, "the tasks (episode i of random tasks resets with SEED+i) and planners")
    add_env(parser, "dlo_env/DLOEndpoint-v0", "the environment", dest="env_id", alias=True)
    parser.add_argument("--threshold", type=number_in(float, 1e-4, 1.0, expected="a number of "
                                                     "metres in [0.0001, 1]"),
                        default=HEADLINE_THRESHOLD, metavar="METRES",
                        help="the environment's success_threshold, judged on the cord at rest "
                             "(the planners take their stopping rules from it); the default, "
                             "0.01, is the README table's, the environments' own is 0.02")
    parser.add_argument("--peg-friction", type=number_in(float, 0.0, 2.0, expected="a friction "
                                                         "coefficient in [0, 2]"),
                        default=None, metavar="MU",
                        help="friction between the cord and the pegs, for suites with pegs "
                             "(the environments' peg_friction; default: frictionless pegs, as "
                             "every suite)")
    add_model(parser)
    add_transition_model(parser)
    parser.add_argument("--network", type=existing_path("distilled network"), default=None,
                        help="distilled network file, or folder holding distilled.pt, for "
                             "latent-mpc-distilled (None: the shipped one for --env; `dlo "
                             "distil` makes one)")
    add_planner_flags(parser)
    add_backend(parser, "this process, one row after the other")
    add_out(parser, "evaluate", "<agent>-<difficulty>.csv/.json and summary.json")


def _file_name(agent: str, label: str) -> str:
    safe = "".join(c if c.isalnum() or c in "-_." else "-" for c in agent.replace("sb3:", "sb3-"))
    return f"{safe.strip('-')}-{label}"


def evaluate_row(agent: str, difficulty: int | None, suite: str | None,
                 settings: dict[str, Any], model: Any = None) -> Any:
    """One row: ``agent`` built from scratch and evaluated (the same in any process).

    Args:
        agent, difficulty, suite: The row.
        settings: The command's flags (``env_id``, ``seed``, ``episodes``, ``split``...).
        model: The loaded shape model of the latent-tree agents (None: loaded here if needed).
    """
    import gymnasium as gym

    import dlo_env  # noqa: F401  (registers the environments)
    from dlo_bench.agents import agent_spec, build_agent, load_shape_model, model_files
    from dlo_bench.evaluation import evaluate

    if settings.get("threads"):
        import torch

        torch.set_num_threads(settings["threads"])
    if model is None and agent_spec(agent).shape_model:
        model = load_shape_model(settings["model"])
    from dlo_bench.evaluation import task_env_kwargs

    # The agent is built for, and evaluated in, one environment: its threshold and success
    # metric, and (for an agent told the cord, such as physics-mpc-true-cord) its cord.
    env_kwargs = {**task_env_kwargs(difficulty, suite), "success_threshold": settings["threshold"]}
    if settings.get("peg_friction") is not None:
        env_kwargs["peg_friction"] = settings["peg_friction"]
    network = ({"baseline": settings["network"]}
               if agent_spec(agent).network and settings.get("network") else {})
    with gym.make(settings["env_id"], **env_kwargs) as env:
        policy = build_agent(agent, env, model=model, seed=settings["seed"],
                             transition_model=settings["transition_model"],
                             replan_every=settings["replan_every"],
                             max_seconds=settings["max_seconds"], **network)
        result = evaluate(policy, env, difficulty=difficulty, suite=suite,
                          episodes=settings["episodes"], seed=settings["seed"],
                          split=settings["split"], agent=agent,
                          fidelity=not settings["no_fidelity"], progress=settings["progress"])
        result.summary["models"] = model_files(agent, env, settings["model"],
                                               settings["transition_model"],
                                               network.get("baseline"))
        return result


def run(args: argparse.Namespace) -> int:
    """Evaluate every agent on every difficulty (or suite), print the table, write files."""
    import platform
    from pathlib import Path

    from dlo_bench.agents import SB3_PREFIX, agent_spec, load_shape_model
    from dlo_bench.report import (
        format_divergence,
        format_legend,
        format_table,
        write_evaluation,
        write_summaries,
    )
    from dlo_env.tasks import SPLIT_SIZES

    specs = [agent_spec(agent) for agent in args.agent]
    for spec in specs:  # every row's agent must act in --env before the first row runs
        if args.env_id not in spec.environments:
            raise InputError(f"--agent {spec.name} acts in {', '.join(spec.environments)}, "
                             f"not in --env {args.env_id}")
    if args.suite and args.episodes > SPLIT_SIZES[args.split]:
        raise InputError(f"--episodes must be at most the {SPLIT_SIZES[args.split]} tasks of "
                         f"a suite's {args.split} split, got {args.episodes}")
    backend = backend_of(args)
    settings = {k: v for k, v in vars(args).items() if not k.startswith("_")}
    model = None
    if any(spec.shape_model for spec in specs):
        import torch

        torch.set_num_threads(args.threads)
        if backend is None:
            model = load_shape_model(args.model)
    rows = ([(None, s, s) for s in args.suite] if args.suite
            else [(d, None, f"d{d}") for d in args.difficulty])
    calls = [(agent, difficulty, suite) for agent in args.agent
             for difficulty, suite, _ in rows]
    labels = [(agent, label) for agent in args.agent for _, _, label in rows]
    out = Path(writable_folder(args.out))
    print(f"success: the cord at rest within {100 * args.threshold:g} cm of the goal "
          f"(--threshold {args.threshold:g})" + (f"; pegs with friction {args.peg_friction:g}"
                                                 if args.peg_friction is not None else ""))
    for agent in args.agent:
        if agent.startswith(SB3_PREFIX):
            from dlo_bench.sb3_models import find_sb3

            print(f"{agent}: {find_sb3(agent[len(SB3_PREFIX):]).describe()}")
    extra = {"arguments": settings, "machine": platform.platform()}
    results: dict[int, Any] = {}

    def finish(k: int, result: Any) -> None:  # written as soon as it is done
        results[k] = result
        write_evaluation(result, out, _file_name(*labels[k]), extra=extra)

    if backend is None:
        for k, (agent, difficulty, suite) in enumerate(calls):
            finish(k, evaluate_row(agent, difficulty, suite, {**settings, "progress": True},
                                   model))
    else:
        quiet = {**settings, "progress": False, **{  # the tasks may run in another folder
            k: str(Path(settings[k]).resolve()) for k in ("model", "transition_model", "network")
            if settings.get(k)}}
        for k, result in backend.map(evaluate_row, [(*c, quiet) for c in calls]):
            finish(k, result)
            print(f"{labels[k][0]} {labels[k][1]}: success "
                  f"{result.summary['success_rate']:.0%}", flush=True)
    summaries = [results[k].summary for k in range(len(calls))]
    print(format_table(summaries))
    print(format_legend(args.threshold))
    parting = format_divergence(summaries)
    if parting:
        print("\nwhere plans and the real cord part ways: mean error (cm) of the first plan's "
              "shapes,\nby distance the end has travelled and by straight move")
        print(parting)
    write_summaries(summaries, out / "summary.json")
    print(f"wrote {len(summaries)} CSV and JSON files and summary.json to {out}")
    return 0
