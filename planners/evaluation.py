"""The evaluation harness: run any policy in a ``dlo_env`` environment and score what the cord did.

A policy is anything with Stable-Baselines3's ``predict(obs, state, episode_start,
deterministic) -> (action, state)``: ``PlannerPolicy``, ``StraightLinePolicy``, the
physics-in-the-loop planner, or a trained SB3 model. ``reset()`` is called at every episode
start when the policy has one. Policies that plan expose ``stats`` (with ``seconds``, and
``plans``/``failures`` counts); those with a ``plans`` list get the transition fidelity of the
plan made from the episode's start.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import tempfile
import time
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

#: Columns of the printed table: (summary key, header, format).
TABLE_COLUMNS = (
    ("agent", "agent", "{}"),
    ("difficulty", "diff", "{}"),
    ("episodes", "episodes", "{}"),
    ("success_rate", "success", "{:.0%}"),
    ("median_final_error", "median err (cm)", "{:.2f}"),
    ("mean_final_error", "mean err (cm)", "{:.2f}"),
    ("mean_steps", "steps", "{:.1f}"),
    ("median_planning_seconds", "plan s (median)", "{:.3f}"),
    ("planning_failures", "plan fails", "{}"),
    ("mean_fidelity", "fidelity (cm)", "{:.2f}"),
)
_CENTIMETRES = {"median_final_error", "mean_final_error", "mean_fidelity"}


@dataclass(frozen=True)
class EpisodeRecord:
    """What happened in one episode; distances in metres, times in seconds.

    Attributes:
        episode: Index in the evaluation.
        seed: Reset seed (``-1`` for suite tasks, which carry their own).
        task_seed: Seed of the task the environment made (or the suite's), ``-1`` if none.
        difficulty: Straight moves of the task.
        success: Whether the episode ended solved (the environment terminates on success).
        start_error: ``error(start, goal)``.
        final_error: ``error(cord, goal)`` at the last step.
        final_max_error: Largest per-point distance at the last step.
        steps: Environment steps taken.
        seconds: Wall time of all ``predict`` calls (planning and inference).
        planning_seconds: Time the policy reports spending on planning (``seconds`` if it
            reports none).
        plans: Planning calls (0 for policies that do not plan).
        planning_failures: Plans that did not reach the goal.
        fidelity: Transition fidelity of the episode's first plan (NaN without plans).
        plan_final_error: ``error`` between that plan's last shape and the real cord at rest
            after executing it (NaN without plans).
    """

    episode: int
    seed: int
    task_seed: int
    difficulty: int
    success: bool
    start_error: float
    final_error: float
    final_max_error: float
    steps: int
    seconds: float
    planning_seconds: float
    plans: int
    planning_failures: int
    fidelity: float
    plan_final_error: float


@dataclass(frozen=True)
class Evaluation:
    """Per-episode records and their summary (see :func:`summarise`)."""

    records: list[EpisodeRecord]
    summary: dict[str, Any]


def _nanstat(values: list[float], fn: Any) -> float:
    arr = np.asarray(values, dtype=np.float64)
    arr = arr[np.isfinite(arr)]
    return float(fn(arr)) if arr.size else math.nan


def summarise(records: list[EpisodeRecord], agent: str = "", env_id: str = "") -> dict[str, Any]:
    """Success rate, median and mean final error, steps, planning seconds and fidelity.

    Returns:
        A JSON-ready dict; ``difficulty`` is the common difficulty or ``"mixed"``.
    """
    if not records:
        raise ValueError("records must not be empty")
    difficulties = sorted({r.difficulty for r in records})
    return {
        "agent": agent,
        "env_id": env_id,
        "difficulty": difficulties[0] if len(difficulties) == 1 else "mixed",
        "episodes": len(records),
        "success_rate": float(np.mean([r.success for r in records])),
        "median_final_error": _nanstat([r.final_error for r in records], np.median),
        "mean_final_error": _nanstat([r.final_error for r in records], np.mean),
        "mean_steps": float(np.mean([r.steps for r in records])),
        "median_planning_seconds": _nanstat([r.planning_seconds for r in records], np.median),
        "mean_planning_seconds": _nanstat([r.planning_seconds for r in records], np.mean),
        "median_seconds": _nanstat([r.seconds for r in records], np.median),
        "planning_failures": int(sum(r.planning_failures for r in records)),
        "plans": int(sum(r.plans for r in records)),
        "mean_fidelity": _nanstat([r.fidelity for r in records], np.mean),
        "median_fidelity": _nanstat([r.fidelity for r in records], np.median),
        "mean_plan_final_error": _nanstat([r.plan_final_error for r in records], np.mean),
    }


def _episode_options(
    difficulty: int | None, suite: str | None, split: str, episodes: int, grasp: str
) -> list[dict[str, Any] | None]:
    if suite is not None:
        from dlo_env.tasks import load_suite

        tasks = load_suite(suite, split, grasp=grasp, limit=episodes)
        if len(tasks) < episodes:
            raise ValueError(
                f"episodes must be at most the {len(tasks)} tasks of suite {suite!r} split "
                f"{split!r}, got {episodes}"
            )
        return [{"task": t} for t in tasks]
    return [None if difficulty is None else {"difficulty": difficulty}] * episodes


def evaluate(
    policy: Any,
    env_id: str = "dlo_env/DLOEndpoint-v0",
    difficulty: int | None = None,
    suite: str | None = None,
    episodes: int = 10,
    seed: int = 0,
    *,
    split: str = "test",
    agent: str = "",
    fidelity: bool = True,
    env_kwargs: dict[str, Any] | None = None,
    progress: bool = False,
) -> Evaluation:
    """Run ``episodes`` episodes of ``policy`` and score them against the real cord.

    Args:
        policy: Anything with SB3's ``predict(obs, state, episode_start, deterministic)``.
        env_id: A ``dlo_env`` goal environment id.
        difficulty: Straight moves per task (the environment's default if None).
        suite: A named suite (``linear-1``, ...) instead of ``difficulty``: its fixed tasks.
        episodes: Number of episodes.
        seed: Episode ``i`` resets with seed ``seed + i`` (random tasks).
        split: The suite's split, ``"test"`` or ``"train"``.
        agent: Name of the agent in the summary.
        fidelity: Compute the transition fidelity of plans (one extra simulation per episode).
        env_kwargs: Extra keyword arguments of ``gym.make``.
        progress: Show a tqdm progress bar.

    Returns:
        The records and their summary.
    """
    import gymnasium as gym

    import dlo_env  # noqa: F401  (registers the environments)
    from dlo_env.shapes import error as shape_error
    from planners.fidelity import transition_fidelity

    if not callable(getattr(policy, "predict", None)):
        raise ValueError(f"policy must have a predict() method, got {type(policy).__name__}")
    if not (isinstance(episodes, int) and episodes >= 1):
        raise ValueError(f"episodes must be an int >= 1, got {episodes!r}")
    if difficulty is not None and suite is not None:
        raise ValueError("give difficulty or suite, not both")
    env = gym.make(env_id, **(env_kwargs or {}))
    try:
        base = env.unwrapped
        if hasattr(policy, "check_env"):
            policy.check_env(env)
        grasp = getattr(getattr(base, "cord", None), "grasp", "head")
        options = _episode_options(difficulty, suite, split, episodes, grasp)
        n = base.params.n_points
        records = []
        bar = None
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=episodes, desc=agent or "evaluate", unit="episode")
        for i, opts in enumerate(options):
            reset_seed = seed + i if suite is None else None
            obs, info = env.reset(seed=reset_seed, options=opts)
            start = np.asarray(obs["achieved_goal"], dtype=np.float32).reshape(n, 2)
            goal = np.asarray(obs["desired_goal"], dtype=np.float32).reshape(n, 2)
            task_seed = int(info.get("task_seed", -1))
            task_difficulty = int(info.get("difficulty", difficulty or 0))
            if hasattr(policy, "reset"):
                policy.reset()
            state, episode_start, steps, seconds = None, True, 0, 0.0
            while True:
                t0 = time.perf_counter()
                action, state = policy.predict(
                    obs, state=state, episode_start=np.array([episode_start]), deterministic=True
                )
                seconds += time.perf_counter() - t0
                episode_start = False
                obs, _, terminated, truncated, info = env.step(np.asarray(action).reshape(-1))
                steps += 1
                if terminated or truncated:
                    break
            stats = getattr(policy, "stats", None)
            plans = list(getattr(policy, "plans", []) or [])
            fid, plan_final = math.nan, math.nan
            if fidelity and plans:
                result = transition_fidelity(plans[0], start, params=base.params,
                                             max_step=base.max_step)
                fid, plan_final = result.mean_error, result.final_error
            records.append(
                EpisodeRecord(
                    episode=i,
                    seed=-1 if reset_seed is None else int(reset_seed),
                    task_seed=task_seed,
                    difficulty=task_difficulty,
                    success=bool(info["is_success"]),
                    start_error=float(shape_error(start, goal)),
                    final_error=float(info["error"]),
                    final_max_error=float(info["max_error"]),
                    steps=steps,
                    seconds=seconds,
                    planning_seconds=float(getattr(stats, "seconds", seconds)),
                    plans=int(getattr(stats, "plans", 0)),
                    planning_failures=int(getattr(stats, "failures", 0)),
                    fidelity=fid,
                    plan_final_error=plan_final,
                )
            )
            if bar is not None:
                bar.update(1)
                bar.set_postfix(success=f"{np.mean([r.success for r in records]):.0%}")
        if bar is not None:
            bar.close()
    finally:
        env.close()
    return Evaluation(records=records, summary=summarise(records, agent=agent, env_id=env_id))


def format_table(summaries: list[dict[str, Any]]) -> str:
    """A plain-text table of summaries, one row each (errors and fidelity in centimetres)."""
    rows = [[header for _, header, _ in TABLE_COLUMNS]]
    for s in summaries:
        row = []
        for key, _, fmt in TABLE_COLUMNS:
            value = s.get(key, "")
            if isinstance(value, float) and math.isnan(value):
                row.append("-")
                continue
            if key in _CENTIMETRES and isinstance(value, float):
                value = 100.0 * value
            row.append(fmt.format(value) if value != "" else "")
        rows.append(row)
    widths = [max(len(r[c]) for r in rows) for c in range(len(rows[0]))]
    lines = ["  ".join(cell.rjust(w) for cell, w in zip(r, widths)) for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def _write_atomic(path: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    try:
        with os.fdopen(fd, "w", newline="") as f:
            f.write(text)
        os.chmod(tmp, 0o644)  # mkstemp makes 0600; results are meant to be shared
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _json_ready(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_ready(v) for v in value]
    if isinstance(value, (np.integer, np.floating, np.bool_)):
        return _json_ready(value.item())
    return value


def write_summaries(summaries: list[dict[str, Any]], path: str | os.PathLike) -> Path:
    """Write a list of summaries to a JSON file atomically (NaN becomes ``null``)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    _write_atomic(path, json.dumps(_json_ready(summaries), indent=2) + "\n")
    return path


def write_evaluation(
    evaluation: Evaluation,
    folder: str | os.PathLike,
    name: str,
    extra: dict[str, Any] | None = None,
) -> tuple[Path, Path]:
    """Write ``<name>.csv`` (one row per episode) and ``<name>.json`` (summary, records, extra).

    Files are written atomically; NaN becomes an empty CSV cell and JSON ``null``.

    Returns:
        The CSV and JSON paths.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    names = [f.name for f in fields(EpisodeRecord)]
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=names)
    writer.writeheader()
    for record in evaluation.records:
        row = asdict(record)
        writer.writerow({k: ("" if isinstance(v, float) and math.isnan(v) else v)
                         for k, v in row.items()})
    csv_path, json_path = folder / f"{name}.csv", folder / f"{name}.json"
    _write_atomic(csv_path, buffer.getvalue())
    data = {
        "summary": evaluation.summary,
        "records": [asdict(r) for r in evaluation.records],
        **(extra or {}),
    }
    _write_atomic(json_path, json.dumps(_json_ready(data), indent=2) + "\n")
    return csv_path, json_path
