"""The comparison benchmark: every agent on the test suites, one table.

``run_benchmark`` evaluates the registered agents (``dlo_bench.agents.AGENTS``: the
straight-line reference, the latent-tree planner open and closed loop, the physics-in-the-loop
planner and the Stable-Baselines3 baselines) on the test split of the suites ``linear-1``,
``linear-2`` and ``linear-3`` (fixed tasks, so every agent sees the same episodes) with
:func:`dlo_bench.evaluation.evaluate`. An agent whose model is missing gets a row that says so,
never silently none. Every finished (agent, difficulty) cell is written at once, so an
interrupted run resumes; :func:`dlo_bench.benchmark_report.write_results` then writes the table
(Markdown), the rows (JSON) and a bar chart (PNG), all atomically.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dlo_bench.agents import AGENTS, build_agent
from dlo_bench.evaluation import EpisodeRecord, Evaluation, evaluate, summarise
from dlo_bench.paths import shape_model_file, shipped_baseline
from dlo_bench.report import json_ready, write_evaluation
from dlo_env.tasks import SPLIT_SIZES, SUITES
from planners.interfaces import Policy, ShapeSurrogate
from planners.policy import DEFAULT_REPLAN_EVERY

#: The test suite of every difficulty: ``linear-K`` holds tasks of K straight moves.
SUITE_OF_DIFFICULTY = {difficulty: name for name, difficulty in SUITES.items()}
#: Episodes of every cell in ``--quick`` runs.
QUICK_EPISODES = 2
#: Subfolder of the output folder holding one CSV/JSON of episodes per cell.
CELLS_DIR = "results_episodes"


@dataclass(frozen=True)
class BenchmarkConfig:
    """What the benchmark runs; the defaults are those of the published table.

    Attributes:
        agents: Agent names (keys of ``dlo_bench.agents.AGENTS``), in table order.
        difficulties: Difficulties; each is the test split of its suite ``linear-K``.
        episodes: Episodes per cell (the first tasks of the split; the split has 50).
        seed: Seed of the planners' sampling.
        env_id: The environment.
        baselines: Folder with one ``dlo baseline`` output folder per RL agent (``ppo/``,
            ``sac-her/``); None: the shipped ones in ``dlo_bench/pretrained``.
        model: Shape model file or folder of the latent-tree agents (None: the shipped one).
        replan_every: Steps between replans of ``latent-tree-closed``.
        max_seconds: Time budget of one latent-tree plan (None: the planner's default).
        fidelity: Compute the transition fidelity of each first latent-tree plan.
    """

    agents: tuple[str, ...] = tuple(AGENTS)
    difficulties: tuple[int, ...] = tuple(SUITE_OF_DIFFICULTY)
    episodes: int = SPLIT_SIZES["test"]
    seed: int = 0
    env_id: str = "dlo_env/DLOEndpoint-v0"
    baselines: str | None = None
    model: str | None = None
    replan_every: int = DEFAULT_REPLAN_EVERY
    max_seconds: float | None = None
    fidelity: bool = True

    def __post_init__(self) -> None:
        unknown = [a for a in self.agents if a not in AGENTS]
        if unknown or not self.agents:
            raise ValueError(f"agents must be a non-empty tuple of {tuple(AGENTS)}, "
                             f"got {self.agents!r}")
        bad = [d for d in self.difficulties if d not in SUITE_OF_DIFFICULTY]
        if bad or not self.difficulties:
            raise ValueError(f"difficulties must be some of {tuple(SUITE_OF_DIFFICULTY)}, "
                             f"got {self.difficulties!r}")
        size = SPLIT_SIZES["test"]
        if not (isinstance(self.episodes, int) and 1 <= self.episodes <= size):
            raise ValueError(f"episodes must be an int in 1..{size} (the test split), "
                             f"got {self.episodes!r}")


@dataclass(frozen=True)
class LoadedAgent:
    """An agent ready to run, or the reason it cannot.

    Attributes:
        name: Agent name.
        policy: The policy, or None when ``missing`` says why not.
        missing: Why the agent has no policy (empty when it has one).
        training_env_steps: Environment steps of training (RL agents), else None.
        model: Where its model came from ("" for model-free planners).
    """

    name: str
    policy: Policy | None
    missing: str = ""
    training_env_steps: int | None = None
    model: str = ""


def load_agent(name: str, config: BenchmarkConfig, env: Any,
               shape_model: ShapeSurrogate | None = None) -> LoadedAgent:
    """Build the agent called ``name`` for ``env``, or say why it is missing.

    Args:
        name: A key of ``AGENTS``.
        config: The benchmark (baselines folder, replanning, time budget, seed).
        env: The environment (for the cord and ``max_step``).
        shape_model: The loaded shape model for the latent-tree agents (None: missing).
    """
    spec = AGENTS[name]
    if spec.extra == "rl":
        from dlo_bench.baselines import read_baseline_metadata

        folder = Path(config.baselines) / name if config.baselines else shipped_baseline(name)
        try:
            meta = read_baseline_metadata(folder)
            policy = build_agent(name, env, baseline=folder)
        except (FileNotFoundError, ValueError) as exc:
            return LoadedAgent(name, None, missing=f"no trained model: {exc}".splitlines()[0])
        return LoadedAgent(name, policy, training_env_steps=int(meta["trained_timesteps"]),
                           model=str(folder / "model.zip"))
    if spec.shape_model:
        if shape_model is None:
            return LoadedAgent(name, None, missing="no shape model (pass --model, or ship "
                                                   "latent_model/pretrained/model.pt)")
        policy = build_agent(name, env, model=shape_model, seed=config.seed,
                             replan_every=config.replan_every, max_seconds=config.max_seconds)
        return LoadedAgent(name, policy, model=str(shape_model_file(config.model)))
    return LoadedAgent(name, build_agent(name, env, seed=config.seed))


def load_shape_model(path: str | None) -> tuple[ShapeSurrogate | None, str]:
    """The shape model at ``path`` (None: the shipped one), or None and why it is missing."""
    from dlo_bench.agents import load_shape_model as load

    try:
        return load(path), ""
    except (FileNotFoundError, ValueError) as exc:
        return None, str(exc).splitlines()[0]


def file_digest(path: str | os.PathLike) -> str:
    """The first 16 hex digits of the SHA-256 of a file ("" if there is none)."""
    p = Path(path)
    if not p.is_file():
        return ""
    return hashlib.sha256(p.read_bytes()).hexdigest()[:16]


def cell_key(config: BenchmarkConfig, agent: LoadedAgent, difficulty: int) -> dict[str, Any]:
    """What a cell's result depends on; a saved cell is reused only when its key matches."""
    key = asdict(config)
    key.pop("agents")
    key.pop("difficulties")
    return {**key, "agent": agent.name, "difficulty": difficulty,
            "model_digest": file_digest(agent.model) if agent.model else ""}


def row_of(agent: LoadedAgent, difficulty: int, evaluation: Evaluation | None,
           episodes: int) -> dict[str, Any]:
    """One row of the results: the summary of a cell, or a row saying the agent is missing."""
    row: dict[str, Any] = {
        "agent": agent.name,
        "difficulty": difficulty,
        "suite": f"{SUITE_OF_DIFFICULTY[difficulty]}/test",
        "status": "ok" if not agent.missing else "missing",
        "note": agent.missing,
        "episodes": episodes if evaluation is not None else 0,
        "success_rate": None,
        "median_error": None,
        "mean_error": None,
        "seconds_per_episode": None,
        "median_seconds_per_episode": None,
        "total_seconds": None,
        "mean_steps": None,
        "planning_failures": None,
        "mean_fidelity": None,
        "training_env_steps": agent.training_env_steps,
        "model": agent.model,
        "wall_seconds": None,
        "commit": "",
    }
    if evaluation is not None:
        records, s = evaluation.records, evaluation.summary
        seconds = [r.planning_seconds for r in records]
        row.update(
            success_rate=s["success_rate"],
            median_error=s["median_final_error"],
            mean_error=s["mean_final_error"],
            seconds_per_episode=float(np.mean(seconds)),
            median_seconds_per_episode=float(np.median(seconds)),
            total_seconds=float(np.sum(seconds)),
            mean_steps=s["mean_steps"],
            planning_failures=s["planning_failures"],
            mean_fidelity=s["mean_fidelity"],
        )
    return row


def _load_cell(path: Path, key: dict[str, Any]) -> tuple[Evaluation, dict[str, Any]] | None:
    """A cell written by an earlier run with the same key: its evaluation and run facts."""
    from dataclasses import fields

    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError:
        return None
    if data.get("benchmark_key") != json_ready(key):
        return None
    known = {f.name for f in fields(EpisodeRecord)}
    try:
        records = [EpisodeRecord(**{k: (math.nan if v is None else v)
                                    for k, v in r.items() if k in known})
                   for r in data["records"]]
    except TypeError:  # written by another version of EpisodeRecord: run the cell again
        return None
    facts = {"wall_seconds": data.get("wall_seconds"), "commit": data.get("commit", "")}
    return Evaluation(records, summarise(records, agent=key["agent"], env_id=key["env_id"])), facts


def code_version() -> str:
    """``git`` commit of the code (``+dirty`` with uncommitted changes to Python files), "" outside
    a checkout."""
    import subprocess

    root = Path(__file__).resolve().parent.parent
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, check=True,
                                capture_output=True, text=True, timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--",
                                "*.py"], cwd=root, check=True, capture_output=True, text=True,
                               timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""
    return commit + ("+dirty" if dirty else "")


def _warm_up(policy: Policy, env: Any) -> None:
    """One untimed action on a random task, so first-call costs (torch) are not timed (the
    evaluation's first step has ``episode_start`` true, which resets the policy)."""
    obs, _ = env.reset(seed=2**20, options={"difficulty": 1})
    policy.predict(obs, episode_start=np.array([True]), deterministic=True)


def run_benchmark(config: BenchmarkConfig, out_dir: str | os.PathLike, *,
                  resume: bool = False, progress: bool = True) -> list[dict[str, Any]]:
    """Evaluate every agent on every difficulty's test suite; write each cell as it finishes.

    Args:
        config: What to run.
        out_dir: Output folder; cells go to ``out_dir/results_episodes/<agent>-d<K>.csv/.json``.
        resume: Reuse cells already written by a run with the same settings.
        progress: Show progress bars.

    Returns:
        The rows, agents in ``config.agents`` order, difficulties ascending within an agent.
    """
    import gymnasium as gym

    import dlo_env  # noqa: F401  (registers the environments)

    cells = Path(out_dir) / CELLS_DIR
    shape_model, why = (None, "")
    if any(AGENTS[a].shape_model for a in config.agents):
        shape_model, why = load_shape_model(config.model)
    rows = []
    for name in config.agents:
        env = gym.make(config.env_id)
        try:
            agent = load_agent(name, config, env, shape_model)
            if agent.policy is not None:
                _warm_up(agent.policy, env)
        finally:
            env.close()
        if agent.missing and AGENTS[name].shape_model and why:
            agent = LoadedAgent(name, None, missing=f"no shape model: {why}")
        for difficulty in config.difficulties:
            if agent.policy is None:
                rows.append(row_of(agent, difficulty, None, 0))
                if progress:
                    print(f"{name} d{difficulty}: missing ({agent.missing})", flush=True)
                continue
            key = cell_key(config, agent, difficulty)
            path = cells / f"{name}-d{difficulty}.json"
            loaded = _load_cell(path, key) if resume else None
            if loaded is None:
                t0 = time.perf_counter()
                suite = SUITE_OF_DIFFICULTY[difficulty]
                result = evaluate(agent.policy, config.env_id, suite=suite,
                                  episodes=config.episodes, seed=config.seed, split="test",
                                  agent=name, fidelity=config.fidelity, progress=progress)
                facts = {"wall_seconds": time.perf_counter() - t0, "commit": code_version()}
                write_evaluation(result, cells, f"{name}-d{difficulty}",
                                 extra={"benchmark_key": key, **facts})
            else:
                result, facts = loaded
                if progress:
                    print(f"{name} d{difficulty}: reused {path}", flush=True)
            rows.append({**row_of(agent, difficulty, result, config.episodes), **facts})
    return rows
