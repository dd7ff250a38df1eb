"""``dlo evaluate``: score agents on the cord environment, print a table, write CSV and JSON."""

from __future__ import annotations

import argparse

AGENT_HELP = (
    "latent-tree (open loop), latent-tree-closed (replans), straight-line (reference), "
    "physics-mpc, or sb3:PATH (a folder written by `dlo baseline`); repeat to compare"
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo evaluate``."""
    parser.add_argument("--agent", nargs="+", required=True, metavar="AGENT", help=AGENT_HELP)
    which = parser.add_mutually_exclusive_group()
    which.add_argument("--difficulty", type=int, nargs="+", default=[1], metavar="K",
                       help="straight moves per random task, 1-5; several give several rows "
                            "(default 1)")
    which.add_argument("--suite", nargs="+", metavar="NAME",
                       help="named task suites instead (linear-1, linear-2, linear-3)")
    parser.add_argument("--split", default="test", choices=("test", "train"),
                        help="split of the suites (default test)")
    parser.add_argument("--episodes", type=int, default=20, help="episodes per row (default 20)")
    parser.add_argument("--seed", type=int, default=0,
                        help="episode i of random tasks resets with seed+i; also the planner's "
                             "seed (default 0)")
    parser.add_argument("--env-id", default="dlo_env/DLOEndpoint-v0")
    parser.add_argument("--model", default=None,
                        help="shape model file or folder for the latent-tree agents "
                             "(default: the shipped pretrained model)")
    parser.add_argument("--replan-every", type=int, default=10,
                        help="steps between replans of latent-tree-closed (default 10)")
    parser.add_argument("--max-seconds", type=float, default=None,
                        help="time budget of one latent-tree plan, seconds")
    parser.add_argument("--threads", type=int, default=1,
                        help="torch CPU threads (default 1: the model is small, and extra "
                             "threads only contend on a shared machine)")
    parser.add_argument("--no-fidelity", action="store_true",
                        help="skip the transition fidelity simulation of each first plan")
    parser.add_argument("--out", default="runs/evaluate",
                        help="folder for <agent>-<difficulty>.csv/.json and summary.json "
                             "(default runs/evaluate)")


def _file_name(agent: str, label: str) -> str:
    safe = "".join(c if c.isalnum() or c in "-_." else "-" for c in agent.replace("sb3:", "sb3-"))
    return f"{safe.strip('-')}-{label}"


def run(args: argparse.Namespace) -> int:
    """Evaluate every agent on every difficulty (or suite), print the table, write files."""
    import platform
    import sys
    from pathlib import Path

    import gymnasium as gym

    import dlo_env  # noqa: F401  (registers the environments)
    from planners.agents import build_agent
    from planners.evaluation import (
        evaluate,
        format_divergence,
        format_table,
        write_evaluation,
        write_summaries,
    )

    if args.episodes < 1:
        print(f"dlo evaluate: --episodes must be >= 1, got {args.episodes}", file=sys.stderr)
        return 2
    model = None
    if any(a.startswith("latent-tree") for a in args.agent):
        import torch

        from latent_model import ShapeModel

        torch.set_num_threads(max(1, args.threads))

        try:
            model = ShapeModel.load_or_pretrained(args.model, device="cpu")
        except FileNotFoundError as exc:
            print(f"dlo evaluate: no shape model: {exc}. Train one with `dlo train` or pass "
                  "--model.", file=sys.stderr)
            return 2
    overrides = {} if args.max_seconds is None else {"max_seconds": args.max_seconds}
    rows = ([(None, s, s) for s in args.suite] if args.suite
            else [(d, None, f"d{d}") for d in args.difficulty])
    out = Path(args.out)
    settings = {k: v for k, v in vars(args).items() if not k.startswith("_")}
    summaries = []
    for agent in args.agent:
        for difficulty, suite, label in rows:
            env = gym.make(args.env_id)
            try:
                policy = build_agent(agent, env, model=model, seed=args.seed,
                                     replan_every=args.replan_every, tree_overrides=overrides)
            except ValueError as exc:
                print(f"dlo evaluate: {exc}", file=sys.stderr)
                return 2
            finally:
                env.close()
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
