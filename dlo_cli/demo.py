"""``dlo demo``: the main job. Plan and execute a few tasks with the shipped model.

Runs the latent-tree planner (open and closed loop) and the straight-line reference on a
handful of random tasks (5 of each difficulty 1-3), prints the results table, and writes into
the output folder: the table as JSON and CSV, ``episode.gif`` (one closed-loop episode of the
hardest difficulty: the real cord, the goal in green and the current plan's shapes as pale
ghosts) and ``interpolation.png`` (the paper's Fig. 2: a latent interpolation, next to a plan
against the real cord).
"""

from __future__ import annotations

import argparse

AGENTS = ("straight-line", "latent-tree", "latent-tree-closed")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo demo``."""
    parser.add_argument("--out", default="dlo-demo", help="output folder (default dlo-demo)")
    parser.add_argument("--model", default=None,
                        help="shape model file or folder (default: the shipped pretrained model)")
    parser.add_argument("--episodes", type=int, default=5,
                        help="tasks per difficulty and agent (default 5)")
    parser.add_argument("--difficulties", type=int, nargs="+", default=[1, 2, 3], metavar="K")
    parser.add_argument("--seed", type=int, default=0, help="seed of tasks and planner")
    parser.add_argument("--threads", type=int, default=1,
                        help="torch CPU threads (default 1: the model is small, and extra "
                             "threads only contend on a shared machine)")


def run(args: argparse.Namespace) -> int:
    """Run the demo; returns the exit code."""
    import sys
    import time
    from pathlib import Path

    t0 = time.perf_counter()
    import gymnasium as gym
    import torch
    from tqdm import tqdm

    import dlo_env  # noqa: F401  (registers the environments)
    from latent_model import ShapeModel
    from planners.agents import build_agent
    from planners.evaluation import evaluate, format_table, write_evaluation, write_summaries
    from planners.fidelity import transition_fidelity
    from planners.figures import record_episode, save_episode_gif, save_interpolation_png
    from planners.interpolation import interpolate
    from planners.latent_tree import LatentTreePlanner

    if args.episodes < 1 or args.threads < 1:
        print("dlo demo: --episodes and --threads must be >= 1", file=sys.stderr)
        return 2
    torch.set_num_threads(args.threads)
    try:
        model = ShapeModel.load_or_pretrained(args.model, device="cpu")
    except FileNotFoundError as exc:
        print(f"dlo demo: no shape model: {exc}. Train one with `dlo train` or pass --model.",
              file=sys.stderr)
        return 2
    env_id = "dlo_env/DLOEndpoint-v0"
    out = Path(args.out)
    print(f"dlo demo: {model!r}\n{len(args.difficulties) * len(AGENTS)} runs of "
          f"{args.episodes} episodes -> {out}")

    summaries = []
    rows = [(d, a) for d in args.difficulties for a in AGENTS]
    for difficulty, agent in tqdm(rows, desc="demo", unit="run"):
        env = gym.make(env_id)
        policy = build_agent(agent, env, model=model, seed=args.seed)
        env.close()
        result = evaluate(policy, env_id, difficulty=difficulty, episodes=args.episodes,
                          seed=args.seed + 1000 * difficulty, agent=agent)
        write_evaluation(result, out, f"{agent}-d{difficulty}")
        summaries.append(result.summary)
    print(format_table(summaries))
    write_summaries(summaries, out / "summary.json")

    # One closed-loop episode as a GIF: the real cord, the goal, the current plan as ghosts.
    # The hardest difficulty asked for: its plans have several moves and the policy replans.
    gif_difficulty = max(args.difficulties)
    env = gym.make(env_id)
    policy = build_agent("latent-tree-closed", env, model=model, seed=args.seed)
    frames, info = record_episode(policy, env, seed=args.seed + 1000 * gif_difficulty,
                                  options={"difficulty": gif_difficulty})
    gif = save_episode_gif(frames, out / "episode.gif", fps=round(1.0 / env.unwrapped.params.dt))
    print(f"episode.gif: difficulty {gif_difficulty}, {len(frames) - 1} steps, "
          f"{'solved' if info['is_success'] else 'not solved'}, final error "
          f"{100 * info['error']:.1f} cm, {policy.stats.plans} plans")

    # The paper's Fig. 2 on a difficulty-1 task, next to a plan against the real cord.
    obs, _ = env.reset(seed=args.seed + 1000, options={"difficulty": 1})
    n = model.n_points
    start, goal = obs["achieved_goal"].reshape(n, 2), obs["desired_goal"].reshape(n, 2)
    shapes = interpolate(model, start, goal, steps=8)
    plan = LatentTreePlanner(model, seed=args.seed).plan(start, goal)
    fidelity = transition_fidelity(plan, start, params=env.unwrapped.params,
                                   max_step=env.unwrapped.max_step)
    env.close()
    png = save_interpolation_png(
        out / "interpolation.png", shapes, start, goal, plan.shapes, fidelity.real_shapes,
        title=f"difficulty-1 task: plan {'found' if plan.success else 'failed'} in "
              f"{plan.stats['seconds']:.2f} s; transition fidelity "
              f"{100 * fidelity.mean_error:.1f} cm",
    )
    print(f"wrote {gif} and {png}; results in {out}/summary.json "
          f"({time.perf_counter() - t0:.0f} s)")
    return 0
