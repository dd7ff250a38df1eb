"""The comparison benchmark: every agent on the test suites, one table.

``run_benchmark`` evaluates the straight-line reference, the latent-tree planner (open and
closed loop), the physics-in-the-loop planner and the Stable-Baselines3 baselines on the test
split of the suites ``linear-1``, ``linear-2`` and ``linear-3`` (fixed tasks, so every agent sees
the same episodes) with the harness of :mod:`planners.evaluation`. An agent whose model is
missing gets a row that says so, never silently none. Every finished (agent, difficulty) cell
is written at once, so an interrupted run resumes; ``write_results`` then writes the table
(Markdown), the rows (JSON) and a bar chart (PNG), all atomically.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import platform
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dlo_env.atomic import atomic_path, write_text_atomic
from planners.evaluation import Evaluation, evaluate, json_ready, write_evaluation

#: The agents of the benchmark, in table order.
AGENTS = ("straight-line", "latent-tree", "latent-tree-closed", "physics-mpc", "ppo", "sac-her")
#: The reinforcement-learning agents: loaded from ``<models_dir>/<name>/``.
RL_AGENTS = ("ppo", "sac", "sac-her")
#: Test suite of every difficulty.
SUITES = {1: "linear-1", 2: "linear-2", 3: "linear-3"}
#: Episodes of every cell in ``--quick`` runs.
QUICK_EPISODES = 2
#: Subfolder of the output folder holding one CSV/JSON of episodes per cell.
CELLS_DIR = "results_episodes"


@dataclass(frozen=True)
class BenchmarkConfig:
    """What the benchmark runs; the defaults are those of the published table.

    Attributes:
        agents: Agent names (from ``AGENTS``).
        difficulties: Difficulties; each is the test split of its suite ``linear-K``.
        episodes: Episodes per cell (the first tasks of the split; the split has 50).
        seed: Seed of the planners' sampling.
        env_id: The environment.
        models_dir: Folder with one ``dlo baseline`` output folder per RL agent
            (``ppo/``, ``sac-her/``).
        shape_model: Shape model file of the latent-tree agents (None: the shipped one).
        replan_every: Steps between replans of ``latent-tree-closed``.
        max_seconds: Time budget of one latent-tree plan (None: the planner's default).
        fidelity: Compute the transition fidelity of each first latent-tree plan.
    """

    agents: tuple[str, ...] = AGENTS
    difficulties: tuple[int, ...] = (1, 2, 3)
    episodes: int = 50
    seed: int = 0
    env_id: str = "dlo_env/DLOEndpoint-v0"
    models_dir: str = "benchmarks/models"
    shape_model: str | None = None
    replan_every: int = 10
    max_seconds: float | None = None
    fidelity: bool = True

    def __post_init__(self) -> None:
        unknown = [a for a in self.agents if a not in AGENTS + RL_AGENTS]
        if unknown or not self.agents:
            raise ValueError(f"agents must be a non-empty tuple of {AGENTS + RL_AGENTS}, "
                             f"got {self.agents!r}")
        bad = [d for d in self.difficulties if d not in SUITES]
        if bad or not self.difficulties:
            raise ValueError(f"difficulties must be some of {tuple(SUITES)}, "
                             f"got {self.difficulties!r}")
        if not (isinstance(self.episodes, int) and 1 <= self.episodes <= 50):
            raise ValueError(f"episodes must be an int in 1..50 (the test split), "
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
    policy: Any
    missing: str = ""
    training_env_steps: int | None = None
    model: str = ""


def load_agent(name: str, config: BenchmarkConfig, env: Any, shape_model: Any = None
               ) -> LoadedAgent:
    """Build the agent called ``name`` for ``env``, or say why it is missing.

    Args:
        name: One of ``AGENTS`` or ``RL_AGENTS``.
        config: The benchmark (models folder, replanning, time budget, seed).
        env: The environment (for the cord and ``max_step``).
        shape_model: The loaded shape model for the latent-tree agents (None: missing).
    """
    from planners.agents import build_agent

    if name in RL_AGENTS:
        from planners.rl_baseline import read_baseline_metadata

        folder = Path(config.models_dir) / name
        try:
            meta = read_baseline_metadata(folder)
        except (FileNotFoundError, ValueError) as exc:
            return LoadedAgent(name, None, missing=f"no trained model: {exc}".splitlines()[0])
        if meta["config"]["algo"] != name:
            return LoadedAgent(name, None, missing=f"{folder} holds a {meta['config']['algo']} "
                                                   f"model, not {name}")
        policy = build_agent(f"sb3:{folder}", env)
        return LoadedAgent(name, policy, training_env_steps=int(meta["trained_timesteps"]),
                           model=str(folder / "model.zip"))
    if name.startswith("latent-tree"):
        if shape_model is None:
            return LoadedAgent(name, None, missing="no shape model (pass --shape-model, or "
                                                   "ship latent_model/pretrained/model.pt)")
        overrides = {} if config.max_seconds is None else {"max_seconds": config.max_seconds}
        policy = build_agent(name, env, model=shape_model, seed=config.seed,
                             replan_every=config.replan_every, tree_overrides=overrides)
        return LoadedAgent(name, policy, model=str(shape_model_path(config.shape_model)))
    return LoadedAgent(name, build_agent(name, env, seed=config.seed))


def shape_model_path(path: str | None) -> Path:
    """The file of the shape model: ``path`` (a file, or a folder with ``model.pt``) or the
    shipped ``latent_model/pretrained/model.pt`` when None."""
    if path is None:
        from importlib import resources

        return Path(str(resources.files("latent_model") / "pretrained" / "model.pt"))
    p = Path(path)
    return p / "model.pt" if p.is_dir() else p


def load_shape_model(path: str | None) -> tuple[Any, str]:
    """The shape model at ``path`` (None: the shipped one), or None and why it is missing."""
    from latent_model import ShapeModel

    try:
        model = ShapeModel.load(shape_model_path(path), device="cpu")
    except (FileNotFoundError, ValueError) as exc:
        return None, str(exc).splitlines()[0]
    return model, ""


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
        "suite": f"{SUITES[difficulty]}/test",
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

    from planners.evaluation import EpisodeRecord, summarise

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


def _warm_up(policy: Any, env: Any) -> None:
    """One untimed action on a random task, so first-call costs (torch) are not timed."""
    obs, _ = env.reset(seed=2**20, options={"difficulty": 1})
    if hasattr(policy, "reset"):
        policy.reset()
    policy.predict(obs, episode_start=np.array([True]), deterministic=True)
    if hasattr(policy, "reset"):
        policy.reset()


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
    if any(a.startswith("latent-tree") for a in config.agents):
        shape_model, why = load_shape_model(config.shape_model)
    rows = []
    for name in config.agents:
        env = gym.make(config.env_id)
        try:
            agent = load_agent(name, config, env, shape_model)
            if agent.policy is not None:
                _warm_up(agent.policy, env)
        finally:
            env.close()
        if agent.missing and name.startswith("latent-tree") and why:
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
                result = evaluate(agent.policy, config.env_id, suite=SUITES[difficulty],
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


def planning_time_ratios(rows: list[dict[str, Any]], slow: str = "physics-mpc",
                         fast: str = "latent-tree") -> dict[str, float]:
    """Total planning seconds of ``slow`` over ``fast`` on the same episodes, per difficulty.

    Returns:
        ``{"d1": ratio, ..., "all": ratio}`` for the difficulties both agents ran.
    """
    by = {(r["agent"], r["difficulty"]): r for r in rows if r["status"] == "ok"}
    ratios, slow_total, fast_total = {}, 0.0, 0.0
    for (agent, difficulty), row in sorted(by.items(), key=lambda kv: kv[0][1]):
        other = by.get((fast, difficulty))
        if agent != slow or other is None or other["episodes"] != row["episodes"]:
            continue
        if other["total_seconds"] > 0:
            ratios[f"d{difficulty}"] = row["total_seconds"] / other["total_seconds"]
        slow_total += row["total_seconds"]
        fast_total += other["total_seconds"]
    if ratios and fast_total > 0:
        ratios["all"] = slow_total / fast_total
    return ratios


def machine_description() -> dict[str, Any]:
    """The machine the numbers were measured on."""
    import torch

    return {
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpu_count": os.cpu_count(),
        "python": platform.python_version(),
        "torch": torch.__version__,
        "torch_threads": torch.get_num_threads(),
    }


def _display_path(path: str) -> str:
    """``path`` relative to the working directory when it lies below it."""
    try:
        return str(Path(path).resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return path


def _fmt(value: Any, fmt: str, scale: float = 1.0) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "–"
    return fmt.format(value * scale)


def results_markdown(rows: list[dict[str, Any]], ratios: dict[str, float],
                     machine: dict[str, Any], command: str, seconds: float) -> str:
    """The Markdown report: the table, the speed ratio, missing agents, machine and command."""
    lines = [
        "# Benchmark results",
        "",
        "Every agent on the first N tasks of the test split of `linear-1`, `linear-2`, "
        "`linear-3` (fixed tasks: every agent sees the same episodes) in "
        "`dlo_env/DLOEndpoint-v0`; success means `error <= 2 cm` (mean point distance). "
        "*seconds/episode* is planning (planners) or policy inference (RL) time, mean over "
        "episodes; the simulator's own stepping is not counted.",
        "",
        "| agent | difficulty | episodes | success | median error (cm) | seconds/episode "
        "| training env steps | fidelity (cm) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if r["status"] != "ok":
            lines.append(f"| {r['agent']} | {r['difficulty']} | – | missing | – | – | – | – |")
            continue
        steps = r["training_env_steps"]
        lines.append(
            f"| {r['agent']} | {r['difficulty']} | {r['episodes']} | "
            f"{_fmt(r['success_rate'], '{:.0%}')} | {_fmt(r['median_error'], '{:.2f}', 100)} | "
            f"{_fmt(r['seconds_per_episode'], '{:.3f}')} | "
            f"{'–' if steps is None else f'{steps:,}'} | "
            f"{_fmt(r['mean_fidelity'], '{:.2f}', 100)} |"
        )
    lines.append("")
    if ratios:
        parts = ", ".join(f"{k} {v:.1f}x" for k, v in ratios.items() if k != "all")
        lines.append(f"**Planning time, physics-mpc / latent-tree on the same episodes:** "
                     f"{ratios.get('all', float('nan')):.1f}x ({parts}).")
        closed = planning_time_ratios(rows, fast="latent-tree-closed")
        if closed:
            parts = ", ".join(f"{k} {v:.1f}x" for k, v in closed.items() if k != "all")
            lines.append(f"Against the closed loop (latent-tree-closed, which replans): "
                         f"{closed.get('all', float('nan')):.1f}x ({parts}).")
    else:
        lines.append("**Planning time ratio:** not measured (physics-mpc and latent-tree did "
                     "not both run).")
    missing = sorted({(r["agent"], r["note"]) for r in rows if r["status"] != "ok"})
    if missing:
        lines += ["", "Missing agents:"]
        lines += [f"- `{agent}`: {note}" for agent, note in missing]
    models = sorted({(r["agent"], r["model"]) for r in rows if r["model"]})
    if models:
        lines += ["", "Models (SHA-256 prefix): " + "; ".join(
            f"`{a}` {_display_path(m)} ({file_digest(m)[:8] or 'gone'})" for a, m in models) + "."]
    evaluated = sum(r["wall_seconds"] or 0.0 for r in rows)
    commits = sorted({r["commit"] for r in rows if r.get("commit")})
    lines += [
        "",
        f"Machine: {machine['platform']}, {machine['processor']}, {machine['cpu_count']} CPUs, "
        f"Python {machine['python']}, torch {machine['torch']} "
        f"({machine['torch_threads']} thread(s)). Wall time of the evaluations "
        f"{evaluated / 60:.1f} min (this invocation {seconds / 60:.1f} min).",
        "",
        f"Code: {', '.join(commits) if commits else 'unknown'} (git commit of each cell's run).",
        "",
        f"Command: `{command}`",
        "",
    ]
    return "\n".join(lines)


def plot_results(rows: list[dict[str, Any]], png: str | os.PathLike) -> None:
    """Bar charts of success rate, median error and seconds per episode (missing rows skipped)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    agents = list(dict.fromkeys(r["agent"] for r in rows))
    difficulties = sorted({r["difficulty"] for r in rows})
    by = {(r["agent"], r["difficulty"]): r for r in rows}
    panels = (("success_rate", "success rate", 1.0, False),
              ("median_error", "median final error (cm)", 100.0, False),
              ("seconds_per_episode", "seconds per episode", 1.0, True))
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2))
    width = 0.8 / max(1, len(agents))
    x = np.arange(len(difficulties))
    for ax, (key, label, scale, log) in zip(axes, panels):
        for i, agent in enumerate(agents):
            values = []
            for d in difficulties:
                v = by.get((agent, d), {}).get(key)
                values.append(np.nan if v is None else v * scale)
            ax.bar(x + (i - (len(agents) - 1) / 2) * width, values, width, label=agent)
        ax.set_xticks(x, [f"difficulty {d}" for d in difficulties])
        ax.set_ylabel(label)
        if log:
            ax.set_yscale("log")
        if key == "success_rate":
            ax.set_ylim(0, 1)
        if key == "median_error":
            ax.axhline(2.0, color="k", lw=0.8, ls="--")  # the success threshold
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(agents), fontsize=8,
               frameon=False)
    missing = sorted({r["agent"] for r in rows if r["status"] != "ok"})
    title = "dlo benchmark (test suites)"
    if missing:
        title += " — missing: " + ", ".join(missing)
    fig.suptitle(title)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    with atomic_path(png) as tmp:
        fig.savefig(tmp, dpi=100)
    plt.close(fig)


def write_results(rows: list[dict[str, Any]], out_dir: str | os.PathLike, command: str,
                  seconds: float) -> dict[str, Path]:
    """Write ``results.json``, ``results.md`` and ``results.png`` into ``out_dir`` atomically.

    Returns:
        The paths, by kind (``json``, ``md``, ``png``).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ratios = planning_time_ratios(rows)
    machine = machine_description()
    paths = {"json": out / "results.json", "md": out / "results.md", "png": out / "results.png"}
    write_text_atomic(paths["json"], json.dumps(json_ready(rows), indent=2) + "\n")
    write_text_atomic(paths["md"], results_markdown(rows, ratios, machine, command, seconds))
    plot_results(rows, paths["png"])
    return paths
