"""The run: every cell evaluated, in this process or on a backend, and written as it finishes.
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from dlo_bench.agents import agent_spec
from dlo_bench.benchmark.cells import (
    CELLS_DIR,
    PARTS_DIR,
    _load_cell,
    cell_key,
    cell_name,
    merge_parts,
    part_name,
    split_episodes,
)
from dlo_bench.benchmark.config import (
    SUITE_OF_DIFFICULTY,
    THRESHOLDS,
    BenchmarkConfig,
    absolute_paths,
)
from dlo_bench.benchmark.provenance import code_version, machine_label, new_run_id
from dlo_bench.benchmark.rows import designed_tasks, peg_tasks, row_of
from dlo_bench.evaluation import Evaluation, evaluate, task_env_kwargs
from dlo_bench.loaded_agent import LoadedAgent, load_agent, load_shape_model
from dlo_bench.report import HEADLINE_THRESHOLD, write_evaluation
from dlo_env.designed_suites import DESIGNED_SUITES
from dlo_env.peg_suites import PEGGED_SUITES
from planners.interfaces import Policy, ShapeSurrogate


def _warm_up(policy: Policy, env: Any) -> None:
    """One untimed action on a random task, so first-call costs (torch) are not timed (the
    evaluation's first step has ``episode_start`` true, which resets the policy)."""
    obs, _ = env.reset(seed=2**20, options={"difficulty": 1})
    policy.predict(obs, episode_start=np.array([True]), deterministic=True)


def run_cell(name: str, env_id: str, suite: str | int, config: BenchmarkConfig, *,
             threshold: float = THRESHOLDS[0], shape_model: ShapeSurrogate | None = None,
             threads: int | None = None, progress: bool = False, first: int = 0,
             count: int | None = None) -> tuple[Evaluation, float]:
    """Evaluate one cell, or part of one, with an agent built for it (and warmed up) from
    scratch.

    A cell depends only on its arguments, so it gives the same result in any process, in any
    order, and after an interrupted run: what lets the benchmark resume cell by cell and run its
    cells on Ray.

    Args:
        name, env_id, suite: The cell (a suite's name, or the difficulty K of ``linear-K``).
        threshold: The environment's success threshold, metres (the agent is built for it).
        config: The benchmark (models, seed, episodes...).
        shape_model: The loaded shape model of the latent-tree agents (None: loaded here).
        threads: Torch threads (None: leave as they are).
        progress: Show a progress bar.
        first, count: The part: episodes ``first`` .. ``first + count - 1`` (count None: to
            the cell's last, ``config.episodes``).

    Returns:
        The evaluation and its wall time, seconds.
    """
    import gymnasium as gym

    import dlo_env  # noqa: F401  (registers the environments)

    if threads is not None:
        import torch

        torch.set_num_threads(threads)
    if shape_model is None and agent_spec(name).shape_model:
        shape_model, why = load_shape_model(config.model)
        if shape_model is None:
            raise FileNotFoundError(f"no shape model: {why}")
    if not isinstance(suite, str):
        suite = SUITE_OF_DIFFICULTY[suite]
    # The agent is built for the environment the suite's episodes run in (its threshold, its
    # success metric, and for an agent told the cord, its cord), warmed up and evaluated there.
    kwargs = {**task_env_kwargs(suite=suite), "success_threshold": threshold}
    with gym.make(env_id, **kwargs) as env:
        agent = load_agent(name, config, env, shape_model)
        if agent.policy is None:
            raise ValueError(f"agent {name!r} is missing in {env_id}: {agent.missing}")
        _warm_up(agent.policy, env)
        t0 = time.perf_counter()
        result = evaluate(agent.policy, env, suite=suite,
                          episodes=config.episodes - first if count is None else count,
                          seed=config.seed, split="test", agent=name, fidelity=config.fidelity,
                          progress=progress, first=first)
        return result, time.perf_counter() - t0


def run_benchmark(config: BenchmarkConfig, out_dir: str | os.PathLike, *,
                  resume: bool = False, progress: bool = True,
                  backend: Any = None, run_id: str | None = None,
                  part: int | None = None) -> list[dict[str, Any]]:
    """Evaluate every agent on every cell (environment, suite); write each as it finishes.

    Args:
        config: What to run.
        out_dir: Output folder; cells go to
            ``out_dir/results_episodes/<agent>-<env>-<d<K> or suite>-<threshold>.csv/.json``.
        resume: Reuse cells already written by a run with the same settings.
        progress: Show progress bars.
        backend: None runs the cells one after the other in this process; a
            ``dlo_env.core.ray_backend.RayBackend`` runs them as Ray tasks (same results:
            a cell is self-contained, see :func:`run_cell`).
        run_id: The id recorded with every cell this call evaluates (None: a
            :func:`new_run_id`); reused cells keep the id of the run that timed them.
        part: Episodes per part of a cell (None: whole cells). The parts run as separate
            calls (on a backend, at once: one slow cell keeps every worker busy) and are
            written to ``results_episodes/parts/`` as each finishes, so ``resume`` loses no
            finished part; a cell is written when its last part finishes, and its parts
            deleted. Every episode depends only on its task and the seed, so a cell is the
            same in parts as whole, its wall time the sum of its parts'.

    Returns:
        The rows: agents in ``config.all_agents`` order, then each agent's cells in
        ``config.cells(agent)`` order.
    """
    import gymnasium as gym

    import dlo_env  # noqa: F401  (registers the environments)

    if part is not None and not (isinstance(part, int) and not isinstance(part, bool)
                                 and part >= 1):
        raise ValueError(f"part must be an int >= 1 (episodes per part) or None, got {part!r}")
    folder = Path(out_dir) / CELLS_DIR
    run_id = run_id or new_run_id()
    # The code that runs, read once before any cell is written: a run writing into a tracked
    # folder (``--out benchmarks``) must not mark its own later cells "+dirty".
    version = code_version()
    machine = machine_label()
    shape_model, why = (None, "")
    if any(agent_spec(a).shape_model for a in config.all_agents):
        shape_model, why = load_shape_model(config.model)
    rows: list[dict[str, Any]] = []
    todo: list[tuple[int, str, str, str, float, LoadedAgent, dict[str, Any]]] = []
    for name in config.all_agents:
        # one agent per environment and number of peg slots it observes
        agents: dict[tuple[str, int], LoadedAgent] = {}
        for env_id, pegs in dict.fromkeys(
                (env, task_env_kwargs(suite=suite).get("max_pegs", 0))
                for env, suite, _ in config.cells(name)):
            with gym.make(env_id, max_pegs=pegs) as env:
                agent = load_agent(name, config, env, shape_model)
            if agent.missing.startswith("no shape model") and why:
                agent = LoadedAgent(name, None, missing=f"no shape model: {why}")
            agents[env_id, pegs] = agent
        for env_id, suite, threshold in config.cells(name):
            agent = agents[env_id, task_env_kwargs(suite=suite).get("max_pegs", 0)]
            cell = cell_name(name, env_id, suite, threshold)
            if agent.policy is None:
                rows.append(row_of(agent, env_id, suite, threshold, None, 0))
                if progress:
                    print(f"{cell}: {'missing' if agent.applicable else 'n/a'} "
                          f"({agent.missing})", flush=True)
                continue
            key = cell_key(config, agent, env_id, suite, threshold)
            path = folder / f"{cell}.json"
            loaded = _load_cell(path, key) if resume else None
            if loaded is not None:
                result, facts = loaded
                rows.append({**row_of(agent, env_id, suite, threshold, result,
                                      config.episodes), **facts})
                if progress:
                    print(f"{cell}: reused {path}", flush=True)
                continue
            todo.append((len(rows), name, env_id, suite, threshold, agent, key))
            rows.append({})

    # Cell by cell, every agent of a cell one after the other: an interrupted run leaves whole
    # cells, and the agents of a cell are timed in one run (their time ratio is comparable).
    # The headline threshold's cells first.
    cells = config.cells()
    order = {cell: (cell[2] != HEADLINE_THRESHOLD, i) for i, cell in enumerate(cells)}
    ranks = {name: i for i, name in enumerate(config.all_agents)}
    todo.sort(key=lambda item: (order[(item[2], item[3], item[4])], ranks[item[1]]))

    parts_folder = folder / PARTS_DIR
    calls: list[tuple[int, int, int]] = []  # (todo index, first, count)
    done: dict[int, dict[int, tuple[Evaluation, dict[str, Any]]]] = {}
    for k, (_, name, env_id, suite, threshold, _, key) in enumerate(todo):
        done[k] = {}
        for first, count in split_episodes(config.episodes, part):
            cell = cell_name(name, env_id, suite, threshold)
            path = parts_folder / f"{part_name(cell, first, count)}.json"
            loaded = _load_cell(path, key, full=True) if resume and part is not None else None
            if loaded is not None and len(loaded[0].records) == count:
                done[k][first] = loaded
            else:
                calls.append((k, first, count))

    def finish(k: int, first: int, count: int, result: Evaluation, seconds: float) -> None:
        """Keep a finished part (on disk when the cell has several) and complete its cell."""
        _, name, env_id, suite, threshold, _, key = todo[k]
        facts = {"wall_seconds": seconds, "commit": version, "run": run_id, "machine": machine}
        if len(split_episodes(config.episodes, part)) > 1:
            cell = cell_name(name, env_id, suite, threshold)
            write_evaluation(result, parts_folder, part_name(cell, first, count), extra={
                "benchmark_key": key, **facts, "goals": [g.tolist() for g in result.goals],
                "rest": [r.tolist() for r in result.rest_shapes]})
        done[k][first] = (result, facts)
        complete(k)

    def complete(k: int) -> None:
        """Write cell ``k`` when all its parts are done, and delete its parts."""
        slot, name, env_id, suite, threshold, agent, key = todo[k]
        pieces = split_episodes(config.episodes, part)
        if len(done[k]) < len(pieces):
            return
        cell = cell_name(name, env_id, suite, threshold)
        result, facts = merge_parts([done[k][a] for a, _ in pieces], name, env_id)
        extra: dict[str, Any] = {"benchmark_key": key, **facts}
        shapes = {"goals": [g.tolist() for g in result.goals],
                  "rest": [r.tolist() for r in result.rest_shapes]}
        if suite in DESIGNED_SUITES:  # for the figure of designed shapes
            tasks = designed_tasks(suite, env_id, len(result.records))
            extra["shapes"] = {"seeds": [s for s, _ in tasks], "families": [f for _, f in tasks],
                               **shapes}
        elif suite in PEGGED_SUITES:  # for the figure of routed cords
            made = peg_tasks(suite, env_id, len(result.records))
            extra["shapes"] = {"seeds": [t.seed for t in made], "families": [suite] * len(made),
                               "pegs": [np.asarray(t.pegs).tolist() for t in made],
                               "peg_radius": [float(t.peg_radius) for t in made], **shapes}
        write_evaluation(result, folder, cell, extra=extra)
        rows[slot] = {**row_of(agent, env_id, suite, threshold, result, config.episodes),
                      **facts}
        if parts_folder.is_dir():  # its parts, also those of a run with another part size
            for stale in parts_folder.glob(f"{cell}.episodes-*"):
                stale.unlink(missing_ok=True)
            if not any(parts_folder.iterdir()):
                parts_folder.rmdir()
        if progress and backend is not None:
            print(f"{cell}: success {result.summary['success_rate']:.0%}", flush=True)

    for k in done:  # cells whose every part was reused
        complete(k)
    if backend is None:
        for k, first, count in calls:
            _, name, env_id, suite, threshold, _, _ = todo[k]
            result, seconds = run_cell(name, env_id, suite, config, threshold=threshold,
                                       shape_model=shape_model, progress=progress,
                                       first=first, count=count)
            finish(k, first, count, result, seconds)
    else:
        threads = _torch_threads()
        config = absolute_paths(config)  # the tasks may run in another folder or node
        tasks = [(todo[k][1], todo[k][2], todo[k][3], todo[k][4], config, None, threads, first,
                  count) for k, first, count in calls]
        for i, (result, seconds) in backend.map(_run_cell_task, tasks):
            finish(*calls[i], result, seconds)
    return rows


def _run_cell_task(name: str, env_id: str, suite: str, threshold: float,
                   config: BenchmarkConfig, shape_model: ShapeSurrogate | None,
                   threads: int | None, first: int = 0,
                   count: int | None = None) -> tuple[Evaluation, float]:
    """``run_cell`` with positional arguments, as a Ray task calls it."""
    return run_cell(name, env_id, suite, config, threshold=threshold,
                    shape_model=shape_model, threads=threads, first=first, count=count)


def _torch_threads() -> int | None:
    """This process's torch threads (None without torch), for the workers to match."""
    try:
        import torch
    except ImportError:
        return None
    return torch.get_num_threads()
