"""The run: every cell evaluated, in this process or on a backend, written as it finishes."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
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
    write_cell_of,
)
from dlo_bench.benchmark.config import (
    SUITE_OF_DIFFICULTY,
    THRESHOLDS,
    BenchmarkConfig,
    absolute_paths,
)
from dlo_bench.benchmark.provenance import code_version, machine_label, new_run_id
from dlo_bench.benchmark.rows import designed_tasks, peg_tasks, row_of
from dlo_bench.cell_store import find_cell
from dlo_bench.evaluation import Evaluation, evaluate, task_env_kwargs
from dlo_bench.loaded_agent import LoadedAgent, load_agent, load_shape_model
from dlo_bench.report import HEADLINE_THRESHOLD
from dlo_env.designed_suites import DESIGNED_SUITES
from dlo_env.errors import InputError, MissingFileError
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
            raise MissingFileError(f"no shape model: {why}")
    if not isinstance(suite, str):
        suite = SUITE_OF_DIFFICULTY[suite]
    # The agent is built for the environment the suite's episodes run in (its threshold, its
    # success metric, and for an agent told the cord, its cord), warmed up and evaluated there.
    kwargs = {**task_env_kwargs(suite=suite), "success_threshold": threshold}
    with gym.make(env_id, **kwargs) as env:
        agent = load_agent(name, config, env, shape_model)
        if agent.policy is None:
            raise InputError(f"agent {name!r} is missing in {env_id}: {agent.missing}")
        _warm_up(agent.policy, env)
        t0 = time.perf_counter()
        result = evaluate(agent.policy, env, suite=suite,
                          episodes=config.episodes - first if count is None else count,
                          seed=config.seed, split="test", agent=name, fidelity=config.fidelity,
                          progress=progress, first=first)
        return result, time.perf_counter() - t0


@dataclass(frozen=True)
class PendingCell:
    """A cell this run evaluates (neither missing nor reused).

    Attributes:
        slot: The index of its row in the results.
        name, env_id, suite, threshold: The cell: its agent, environment, suite and success
            threshold.
        agent: Its agent, loaded.
        key: What its result depends on (:func:`cell_key`), written with it.
    """

    slot: int
    name: str
    env_id: str
    suite: str
    threshold: float
    agent: LoadedAgent
    key: dict[str, Any]

    @property
    def file_name(self) -> str:
        """The cell's file name (:func:`cell_name`)."""
        return cell_name(self.name, self.env_id, self.suite, self.threshold)


@dataclass
class _Run:
    """One call of :func:`run_benchmark`: what it runs and records, its rows, the cells it
    evaluates and their finished parts.

    Attributes:
        config, folder, part, progress, backend: As given (``folder``: the cells' folder).
        version, run_id, machine: The facts every cell evaluated here records.
        rows: The results, one per cell (empty while the cell runs).
        todo: The cells to evaluate, in the order they run.
        done: Per cell of ``todo`` (by index), its finished parts by their first episode, each
            with its facts.
    """

    config: BenchmarkConfig
    folder: Path
    part: int | None
    progress: bool
    backend: Any
    version: str
    run_id: str
    machine: str
    rows: list[dict[str, Any]] = field(default_factory=list)
    todo: list[PendingCell] = field(default_factory=list)
    done: dict[int, dict[int, tuple[Evaluation, dict[str, Any]]]] = field(default_factory=dict)

    @property
    def parts_folder(self) -> Path:
        """Where the finished parts of unfinished cells are written."""
        return self.folder / PARTS_DIR

    def finish(self, k: int, first: int, count: int, result: Evaluation, seconds: float) -> None:
        """Keep a finished part (on disk when the cell has several) and complete its cell."""
        cell = self.todo[k]
        facts = {"wall_seconds": seconds, "commit": self.version, "run": self.run_id,
                 "machine": self.machine}
        if len(split_episodes(self.config.episodes, self.part)) > 1:
            write_cell_of(result, self.parts_folder, part_name(cell.file_name, first, count),
                          {"benchmark_key": cell.key, **facts,
                           "goals": [g.tolist() for g in result.goals],
                           "rest": [r.tolist() for r in result.rest_shapes]})
        self.done[k][first] = (result, facts)
        self.complete(k)

    def complete(self, k: int) -> None:
        """Write cell ``k`` when all its parts are done, and delete its parts."""
        cell = self.todo[k]
        pieces = split_episodes(self.config.episodes, self.part)
        if len(self.done[k]) < len(pieces):
            return
        result, facts = merge_parts([self.done[k][a] for a, _ in pieces], cell.name, cell.env_id)
        extra: dict[str, Any] = {"benchmark_key": cell.key, **facts}
        shapes = {"goals": [g.tolist() for g in result.goals],
                  "rest": [r.tolist() for r in result.rest_shapes]}
        if cell.suite in DESIGNED_SUITES:  # for the figure of designed shapes
            tasks = designed_tasks(cell.suite, cell.env_id, len(result.records))
            extra["shapes"] = {"seeds": [s for s, _ in tasks], "families": [f for _, f in tasks],
                               **shapes}
        elif cell.suite in PEGGED_SUITES:  # for the figure of routed cords
            made = peg_tasks(cell.suite, cell.env_id, len(result.records))
            extra["shapes"] = {"seeds": [t.seed for t in made],
                               "families": [cell.suite] * len(made),
                               "pegs": [np.asarray(t.pegs).tolist() for t in made],
                               "peg_radius": [float(t.peg_radius) for t in made], **shapes}
        write_cell_of(result, self.folder, cell.file_name, extra)
        self.rows[cell.slot] = {**row_of(cell.agent, cell.env_id, cell.suite, cell.threshold,
                                         result, self.config.episodes), **facts}
        if self.parts_folder.is_dir():  # its parts, also those of a run with another part size
            for stale in self.parts_folder.glob(f"{cell.file_name}.episodes-*"):
                stale.unlink(missing_ok=True)
            if not any(self.parts_folder.iterdir()):
                self.parts_folder.rmdir()
        if self.progress and self.backend is not None:
            print(f"{cell.file_name}: success {result.summary['success_rate']:.0%}", flush=True)


def run_benchmark(config: BenchmarkConfig, out_dir: str | os.PathLike, *,
                  resume: bool = False, progress: bool = True,
                  backend: Any = None, run_id: str | None = None,
                  part: int | None = None) -> list[dict[str, Any]]:
    """Evaluate every agent on every cell (environment, suite); write each as it finishes.

    Args:
        config: What to run.
        out_dir: Output folder; cells go to
            ``out_dir/results_episodes/<agent>-<env>-<d<K> or suite>-<threshold>.npz``
            (:mod:`dlo_bench.cell_store`).
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
    import dlo_env  # noqa: F401  (registers the environments)

    if part is not None and not (isinstance(part, int) and not isinstance(part, bool)
                                 and part >= 1):
        raise InputError(f"part must be an int >= 1 (episodes per part) or None, got {part!r}")
    folder = Path(out_dir) / CELLS_DIR
    run_id = run_id or new_run_id()
    # The code that runs, read once before any cell is written: a run writing into a tracked
    # folder (``--out benchmarks``) must not mark its own later cells "+dirty".
    version = code_version()
    run = _Run(config, folder, part, progress, backend, version, run_id, machine_label())
    shape_model, why = (None, "")
    if any(agent_spec(a).shape_model for a in config.all_agents):
        shape_model, why = load_shape_model(config.model)
    for name in config.all_agents:
        _add_cells(run, name, _loaded_agents(config, name, shape_model, why), resume)
    _put_in_run_order(config, run.todo)
    calls = _parts_to_run(run, resume)
    for k in run.done:  # cells whose every part was reused
        run.complete(k)
    _evaluate(run, calls, shape_model)
    return run.rows


def _agent_env(env_id: str, suite: str) -> tuple[str, int, Any]:
    """What an agent is built for in a cell: the environment, the peg slots it observes and
    its cord (a designed suite's own, else None)."""
    kwargs = task_env_kwargs(suite=suite)
    return env_id, kwargs.get("max_pegs", 0), kwargs.get("params")


def _loaded_agents(config: BenchmarkConfig, name: str, shape_model: ShapeSurrogate | None,
                   why: str) -> dict[tuple[str, int, Any], LoadedAgent]:
    """Agent ``name`` loaded once per environment, number of peg slots and cord of the cells of
    ``config`` (:func:`_agent_env`); ``why`` says why the shape model is missing (when it
    is)."""
    import gymnasium as gym

    agents: dict[tuple[str, int, Any], LoadedAgent] = {}
    for made in dict.fromkeys(_agent_env(env, suite) for env, suite, _ in config.cells(name)):
        env_id, pegs, params = made
        with gym.make(env_id, max_pegs=pegs, params=params) as env:
            agent = load_agent(name, config, env, shape_model)
        if agent.missing.startswith("no shape model") and why:
            agent = LoadedAgent(name, None, missing=f"no shape model: {why}")
        agents[made] = agent
    return agents


def _add_cells(run: _Run, name: str, agents: dict[tuple[str, int, Any], LoadedAgent],
               resume: bool) -> None:
    """The rows of agent ``name``'s cells: where it is missing, its row says so; a cell
    written by an earlier run with the same key is reused (``resume``); every other cell gets an
    empty row and a place in ``run.todo``."""
    config = run.config
    for env_id, suite, threshold in config.cells(name):
        agent = agents[_agent_env(env_id, suite)]
        cell = cell_name(name, env_id, suite, threshold)
        if agent.policy is None:
            run.rows.append(row_of(agent, env_id, suite, threshold, None, 0))
            if run.progress:
                print(f"{cell}: {'missing' if agent.applicable else 'n/a'} "
                      f"({agent.missing})", flush=True)
            continue
        key = cell_key(config, agent, env_id, suite, threshold)
        loaded = _load_cell(run.folder, cell, key) if resume else None
        if loaded is not None:
            result, facts = loaded
            run.rows.append({**row_of(agent, env_id, suite, threshold, result,
                                      config.episodes), **facts})
            if run.progress:
                print(f"{cell}: reused {find_cell(run.folder, cell)}", flush=True)
            continue
        run.todo.append(PendingCell(len(run.rows), name, env_id, suite, threshold, agent, key))
        run.rows.append({})


def _put_in_run_order(config: BenchmarkConfig, todo: list[PendingCell]) -> None:
    """Sort ``todo`` cell by cell, every agent of a cell one after the other: an interrupted
    run leaves whole cells, and the agents of a cell are timed in one run (their time ratio is
    comparable). The headline threshold's cells first."""
    cells = config.cells()
    order = {cell: (cell[2] != HEADLINE_THRESHOLD, i) for i, cell in enumerate(cells)}
    ranks = {name: i for i, name in enumerate(config.all_agents)}
    todo.sort(key=lambda c: (order[(c.env_id, c.suite, c.threshold)], ranks[c.name]))


def _parts_to_run(run: _Run, resume: bool) -> list[tuple[int, int, int]]:
    """``(index into run.todo, first episode, count)`` of every part to evaluate; the parts
    an earlier run finished (``resume`` with parts) go to ``run.done``."""
    calls: list[tuple[int, int, int]] = []
    for k, cell in enumerate(run.todo):
        run.done[k] = {}
        for first, count in split_episodes(run.config.episodes, run.part):
            loaded = (_load_cell(run.parts_folder, part_name(cell.file_name, first, count),
                                 cell.key, full=True) if resume and run.part is not None
                      else None)
            if loaded is not None and len(loaded[0].records) == count:
                run.done[k][first] = loaded
            else:
                calls.append((k, first, count))
    return calls


def _evaluate(run: _Run, calls: list[tuple[int, int, int]],
              shape_model: ShapeSurrogate | None) -> None:
    """Evaluate the parts ``calls`` (:func:`_parts_to_run`), in this process or on the run's
    backend, each kept as it finishes (:meth:`_Run.finish`)."""
    if run.backend is None:
        for k, first, count in calls:
            cell = run.todo[k]
            result, seconds = run_cell(cell.name, cell.env_id, cell.suite, run.config,
                                       threshold=cell.threshold, shape_model=shape_model,
                                       progress=run.progress, first=first, count=count)
            run.finish(k, first, count, result, seconds)
        return
    threads = _torch_threads()
    config = absolute_paths(run.config)  # the tasks may run in another folder or node
    tasks = [(run.todo[k].name, run.todo[k].env_id, run.todo[k].suite, run.todo[k].threshold,
              config, None, threads, first, count) for k, first, count in calls]
    for i, (result, seconds) in run.backend.map(_run_cell_task, tasks):
        run.finish(*calls[i], result, seconds)


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
