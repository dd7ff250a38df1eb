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
import time
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from dlo_env.atomic import write_text_atomic

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
#: Bins of the distance the manipulated end has travelled along a plan, metres: the
#: divergence table reports the mean fidelity error of the planned shapes in each.
TRAVEL_BINS = (0.0, 0.05, 0.10, 0.20, 0.30, math.inf)
#: Straight moves of a plan reported one by one in the divergence table; later ones together.
MOVE_BINS = 3


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
        fidelity_max: Largest error along that plan (NaN without plans).
        plan_moves: Straight moves of the first plan (0 without plans).
        plan_travel: Distance the end travels in the first plan, metres (NaN without plans).
        start_inversion_error: ``error`` of the first plan's decoded start inversion (NaN
            without plans).
        goal_inversion_error: ``error`` of the decoded goal inversion (NaN if not reported).
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
    fidelity_max: float = math.nan
    plan_moves: int = 0
    plan_travel: float = math.nan
    start_inversion_error: float = math.nan
    goal_inversion_error: float = math.nan


@dataclass(frozen=True)
class FidelityProfile:
    """Where one plan and the real cord part ways: the error at every planned shape.

    Attributes:
        episode: Index of the episode whose first plan this is.
        errors: ``(T,)`` ``error(planned, real)`` at each planned shape, metres.
        travel: ``(T,)`` distance the end had travelled at each planned shape, metres.
        move: ``(T,)`` index of the straight move of each planned shape (0-based).
    """

    episode: int
    errors: np.ndarray
    travel: np.ndarray
    move: np.ndarray


@dataclass(frozen=True)
class Evaluation:
    """Per-episode records, their summary (see :func:`summarise`) and fidelity profiles."""

    records: list[EpisodeRecord]
    summary: dict[str, Any]
    profiles: list[FidelityProfile] = field(default_factory=list)


def _travel_label(low: float, high: float) -> str:
    if math.isinf(high):
        return f">={100 * low:.0f} cm"
    return f"{100 * low:.0f}-{100 * high:.0f} cm"


def divergence(profiles: list[FidelityProfile]) -> dict[str, Any]:
    """Mean fidelity error of planned shapes by end travel and by straight move, metres.

    Pools the planned shapes of all ``profiles``: ``by_travel`` maps each ``TRAVEL_BINS``
    interval to the mean error of the shapes planned there (NaN if none), ``by_move`` the move
    index (``"1"``, ``"2"``, ``"3+"``) to the same; ``at_start`` is the mean error of the first
    planned shapes (the start inversion), ``at_end`` of the last ones; ``plans`` and
    ``shapes`` count them.
    """
    if not profiles:
        return {"plans": 0, "shapes": 0, "at_start": math.nan, "at_end": math.nan, "by_travel": {},
                "by_move": {}}
    errors = np.concatenate([p.errors for p in profiles])
    travel = np.concatenate([p.travel for p in profiles])
    move = np.concatenate([p.move for p in profiles])
    by_travel = {}
    for low, high in zip(TRAVEL_BINS[:-1], TRAVEL_BINS[1:]):
        inside = (travel >= low) & (travel < high)
        by_travel[_travel_label(low, high)] = float(errors[inside].mean()) if inside.any() else (
            math.nan)
    by_move = {}
    for k in range(MOVE_BINS):
        inside = move >= k if k == MOVE_BINS - 1 else move == k
        label = f"{k + 1}+" if k == MOVE_BINS - 1 else str(k + 1)
        by_move[label] = float(errors[inside].mean()) if inside.any() else math.nan
    return {
        "plans": len(profiles),
        "shapes": int(errors.size),
        "at_start": float(np.mean([p.errors[0] for p in profiles])),
        "at_end": float(np.mean([p.errors[-1] for p in profiles])),
        "by_travel": by_travel,
        "by_move": by_move,
    }


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
        "mean_plan_moves": _nanstat([r.plan_moves for r in records if r.plans], np.mean),
        "mean_plan_travel": _nanstat([r.plan_travel for r in records], np.mean),
        "mean_start_inversion_error": _nanstat([r.start_inversion_error for r in records],
                                               np.mean),
        "mean_goal_inversion_error": _nanstat([r.goal_inversion_error for r in records],
                                              np.mean),
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
        records, profiles = [], []
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
            fid = plan_final = fid_max = travel = start_inv = math.nan
            if plans:
                travel = plans[0].path_length
                start_inv = float(plans[0].stats.get("start_inversion_error", math.nan))
            if fidelity and plans:
                result = transition_fidelity(plans[0], start, params=base.params,
                                             max_step=base.max_step)
                fid, plan_final, fid_max = result.mean_error, result.final_error, result.max_error
                profiles.append(FidelityProfile(i, result.errors, result.travel, result.move))
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
                    fidelity_max=fid_max,
                    plan_moves=len(plans[0].nodes) - 1 if plans else 0,
                    plan_travel=travel,
                    start_inversion_error=start_inv,
                    goal_inversion_error=float(getattr(stats, "goal_inversion_error", math.nan)),
                )
            )
            if bar is not None:
                bar.update(1)
                bar.set_postfix(success=f"{np.mean([r.success for r in records]):.0%}")
        if bar is not None:
            bar.close()
    finally:
        env.close()
    summary = summarise(records, agent=agent, env_id=env_id)
    summary["divergence"] = divergence(profiles)
    return Evaluation(records=records, summary=summary, profiles=profiles)


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


def format_divergence(summaries: list[dict[str, Any]]) -> str:
    """A plain-text table of where plans and the real cord part ways (centimetres).

    One row per summary that has plans: the mean error at the plan's first shape (the start
    inversion), by the distance the end has travelled, by straight move, at the plan's last
    shape, and between the plan's last shape and the real cord at rest after it.
    """
    rows = []
    for s in summaries:
        d = s.get("divergence") or {}
        if not d.get("shapes"):
            continue
        rows.append((s, d))
    if not rows:
        return ""
    travel_keys = list(rows[0][1]["by_travel"])
    move_keys = list(rows[0][1]["by_move"])
    header = (["agent", "diff", "plans", "at start"] + [f"travel {k}" for k in travel_keys]
              + [f"move {k}" for k in move_keys] + ["at end", "end at rest"])
    table = [header]
    for s, d in rows:
        values = ([d["at_start"]] + [d["by_travel"].get(k, math.nan) for k in travel_keys]
                  + [d["by_move"].get(k, math.nan) for k in move_keys]
                  + [d["at_end"], s.get("mean_plan_final_error", math.nan)])
        cells = ["-" if not math.isfinite(v) else f"{100 * v:.2f}" for v in values]
        table.append([str(s.get("agent", "")), str(s.get("difficulty", "")),
                      str(d["plans"])] + cells)
    widths = [max(len(r[c]) for r in table) for c in range(len(header))]
    lines = ["  ".join(cell.rjust(w) for cell, w in zip(r, widths)) for r in table]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def json_ready(value: Any) -> Any:
    """``value`` with non-finite floats as None (strict JSON), recursively."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_ready(v) for v in value]
    if isinstance(value, (np.integer, np.floating, np.bool_)):
        return json_ready(value.item())
    return value


def write_summaries(summaries: list[dict[str, Any]], path: str | os.PathLike) -> Path:
    """Write a list of summaries to a JSON file atomically (NaN becomes ``null``)."""
    return write_text_atomic(path, json.dumps(json_ready(summaries), indent=2) + "\n")


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
    write_text_atomic(csv_path, buffer.getvalue())
    data = {
        "summary": evaluation.summary,
        "records": [asdict(r) for r in evaluation.records],
        "fidelity_profiles": [
            {"episode": p.episode, "errors": p.errors.tolist(), "travel": p.travel.tolist(),
             "move": p.move.tolist()}
            for p in evaluation.profiles
        ],
        **(extra or {}),
    }
    write_text_atomic(json_path, json.dumps(json_ready(data), indent=2) + "\n")
    return csv_path, json_path
