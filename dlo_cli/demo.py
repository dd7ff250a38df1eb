"""``dlo demo``: the main job. Plan and execute a few tasks with the shipped models.

Runs latent-mpc (CEM on the learned transition model, the best agent), the paper's latent-tree
planner (open and closed loop) and the straight-line reference on a handful of random tasks
(10 of each difficulty 1-3), prints the results table, and writes into the output folder: the
table as JSON and CSV, ``episode.gif`` (latent-mpc on a test task of linear-5, five straight
moves: the real cord, the gripper and the goal in green) and ``interpolation.png`` (the
paper's Fig. 2: a latent interpolation, next to a plan against the real cord).
"""

from __future__ import annotations

import argparse

from dlo_cli.flags import (
    add_difficulty,
    add_episodes,
    add_model,
    add_out,
    add_seed,
    add_threads,
    add_transition_model,
    writable_folder,
)

AGENTS = ("straight-line", "latent-tree", "latent-tree-closed", "latent-mpc")
#: The agent the GIF shows, and how many test tasks of a suite it tries for a solved one.
GIF_AGENT = "latent-mpc"
GIF_TRIES = 5


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Flags of ``dlo demo``."""
    add_out(parser, "demo", "the tables, episode.gif and interpolation.png")
    add_model(parser)
    add_transition_model(parser)
    add_episodes(parser, "tasks per difficulty and agent")
    add_difficulty(parser, [1, 2, 3], "random tasks; the GIF shows the hardest")
    add_seed(parser, "the tasks and the planners")
    add_threads(parser)


def run(args: argparse.Namespace) -> int:
    """Run the demo; returns the exit code."""
    import time
    from pathlib import Path

    t0 = time.perf_counter()
    import gymnasium as gym
    import torch

    import dlo_env  # noqa: F401  (registers the environments)
    from dlo_bench.agents import build_agent, load_shape_model, load_transition_model
    from dlo_bench.benchmark import HEADLINE_THRESHOLD
    from dlo_bench.charts import save_interpolation_png
    from dlo_bench.evaluation import evaluate
    from dlo_bench.fidelity import transition_fidelity
    from dlo_bench.figures import save_episode_gif
    from dlo_bench.report import format_legend, format_table, write_evaluation, write_summaries
    from dlo_env.core.progress import progress_bar
    from planners.interpolation import interpolate
    from planners.latent_tree import LatentTreePlanner

    torch.set_num_threads(args.threads)
    model = load_shape_model(args.model)
    transition_model = load_transition_model(args.transition_model)
    env_id = "dlo_env/DLOEndpoint-v0"
    env_kwargs = {"success_threshold": HEADLINE_THRESHOLD}  # success as the README defines it
    out = Path(writable_folder(args.out))
    print(f"dlo demo: {model!r}\n{len(args.difficulty) * len(AGENTS)} runs of "
          f"{args.episodes} episodes -> {out}")

    summaries = []
    rows = [(d, a) for d in args.difficulty for a in AGENTS]
    bar = progress_bar(len(rows), "demo", "run")
    for difficulty, agent in rows:
        bar.update(1)
        with gym.make(env_id, **env_kwargs) as env:
            policy = build_agent(agent, env, model=model, transition_model=transition_model,
                                 seed=args.seed)
        result = evaluate(policy, env_id, difficulty=difficulty, episodes=args.episodes,
                          seed=args.seed + 1000 * difficulty, agent=agent,
                          env_kwargs=env_kwargs)
        write_evaluation(result, out, f"{agent}-d{difficulty}")
        summaries.append(result.summary)
    print(format_table(summaries))
    print(format_legend(HEADLINE_THRESHOLD))
    write_summaries(summaries, out / "summary.json")

    # The best agent on the hardest suite it solves: the first solved of a few test tasks of
    # linear-5 (else linear-4, ...), recorded as a GIF of the real cord and the goal.
    env = gym.make(env_id, **env_kwargs)
    policy = build_agent(GIF_AGENT, env, model=model, transition_model=transition_model,
                         seed=args.seed)
    suite, index, frames, info = _hardest_solved(policy, env)
    fps = round(1.0 / env.unwrapped.cord.params.dt)
    gif = save_episode_gif(frames, out / "episode.gif", fps=fps)
    print(f"episode.gif: {GIF_AGENT} on {suite} test task {index + 1}, {len(frames) - 1} steps, "
          f"{'solved' if info['is_success'] else 'not solved'}, final error "
          f"{100 * info['error']:.1f} cm, {info['plans']} plans")

    # The paper's Fig. 2 on a difficulty-1 task, next to a plan against the real cord.
    obs, _ = env.reset(seed=args.seed + 1000, options={"difficulty": 1})
    n = model.n_points
    start, goal = obs["achieved_goal"].reshape(n, 2), obs["desired_goal"].reshape(n, 2)
    shapes = interpolate(model, start, goal, steps=8)
    plan = LatentTreePlanner(model, seed=args.seed).plan(start, goal)
    fidelity = transition_fidelity(plan, start, params=env.unwrapped.cord.params,
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


def _hardest_solved(policy: object, env: object) -> tuple[str, int, list, dict]:
    """Of the first ``GIF_TRIES`` test tasks of linear-5 (else linear-4, ...), the solved one
    whose start was farthest from its goal: its suite, index, frames and last ``info`` with
    the episode's ``plans`` (the last episode tried if none is solved)."""
    from dlo_bench.figures import record_episode
    from dlo_env.shapes import error
    from dlo_env.tasks import load_suite

    for difficulty in range(5, 0, -1):
        suite, best = f"linear-{difficulty}", None
        for index, task in enumerate(load_suite(suite, "test", limit=GIF_TRIES)):
            frames, info = record_episode(policy, env, options={"task": task})
            far = float(error(task.start, task.goal))
            if info["is_success"] and (best is None or far > best[0]):
                best = (far, index, frames, {**info, "plans": policy.episode_stats().plans})
        if best is not None:
            return suite, *best[1:]
    return suite, index, frames, {**info, "plans": policy.episode_stats().plans}
