"""The evaluation harness: run any policy in a ``dlo_env`` environment and score what the cord did.

A policy is a :class:`planners.interfaces.Policy`, Stable-Baselines3's ``predict(obs, state,
episode_start, deterministic) -> (action, state)``: ``PlannerPolicy``, ``StraightLinePolicy``,
the physics-in-the-loop planner, or a trained SB3 model. The first step of every episode has
``episode_start`` true (the policies reset on it). A :class:`planners.interfaces.PlanningPolicy`
is asked for its ``episode_stats()`` after every episode; when it reports a first plan, that
plan's transition fidelity is measured against the simulator.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from dlo_env.core.deprecation import renamed_argument
from dlo_env.core.progress import progress_bar
from dlo_env.errors import InputError
from planners.interfaces import EpisodeStats, PlanningPolicy, Policy

if TYPE_CHECKING:
    import gymnasium as gym

#: Bins of the distance the manipulated end has travelled along a plan, metres: the
#: divergence table reports the mean fidelity error of the planned shapes in each.
TRAVEL_BINS = (0.0, 0.05, 0.10, 0.20, 0.30, math.inf)
#: Straight moves of a plan reported one by one in the divergence table; later ones together.
MOVE_BINS = 3
#: Episodes per row of a quick look (``evaluate``, ``dlo evaluate``, ``dlo demo``): an agent in
#: a minute, not a measurement. ``dlo benchmark`` runs whole test splits instead (50 tasks per
#: cell, ``dlo_bench.benchmark.BenchmarkConfig.episodes``).
DEFAULT_EPISODES = 10
#: The environment ``evaluate`` makes when given none.
DEFAULT_ENV = "dlo_env/DLOEndpoint-v0"


@dataclass(frozen=True)
class EpisodeRecord:
    """What happened in one episode; distances in metres, times in seconds.

    Attributes:
        episode: Index in the evaluation.
        seed: Reset seed (``-1`` for suite tasks, which carry their own).
        task_seed: Seed of the task the environment made (or the suite's), ``-1`` if none.
        difficulty: Straight moves of the task.
        success: Whether the episode ended solved (the environment terminates on success,
            judged on the cord at rest unless it was made with ``judge_at_rest=False``).
        start_error: ``error(start, goal)``.
        final_error: ``error(cord, goal)`` at the last step.
        final_max_error: Largest per-point distance at the last step.
        rest_error: ``error`` of the shape the cord comes to rest in after the last step
            (the environment's ``settled_metrics()``; ``final_error`` when it ended solved on
            a cord judged at rest).
        rest_direction_free_error: The same for ``direction_free_error``.
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
        rest_max_error: Largest per-point distance of the shape at rest (as ``rest_error``;
            NaN in records written before it was recorded).
    """

    episode: int
    seed: int
    task_seed: int
    difficulty: int
    success: bool
    start_error: float
    final_error: float
    final_max_error: float
    rest_error: float
    rest_direction_free_error: float
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
    rest_max_error: float = math.nan


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
    """Per-episode records, their summary (see :func:`summarise`), fidelity profiles, and each
    episode's goal and the shape its cord rests in after the last step (float32 ``(n, 2)``,
    episode order; empty for evaluations read back from a file without them)."""

    records: list[EpisodeRecord]
    summary: dict[str, Any]
    profiles: list[FidelityProfile] = field(default_factory=list)
    goals: list[np.ndarray] = field(default_factory=list)
    rest_shapes: list[np.ndarray] = field(default_factory=list)


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
    """Success rate, median and mean final and at-rest errors, steps, planning seconds and
    fidelity.

    Returns:
        A JSON-ready dict; ``difficulty`` is the common difficulty or ``"mixed"``.
    """
    if not records:
        raise InputError("records must not be empty")
    difficulties = sorted({r.difficulty for r in records})
    return {
        "agent": agent,
        "env_id": env_id,
        "difficulty": difficulties[0] if len(difficulties) == 1 else "mixed",
        "episodes": len(records),
        "success_rate": float(np.mean([r.success for r in records])),
        "median_final_error": _nanstat([r.final_error for r in records], np.median),
        "mean_final_error": _nanstat([r.final_error for r in records], np.mean),
        "median_rest_error": _nanstat([r.rest_error for r in records], np.median),
        "mean_rest_error": _nanstat([r.rest_error for r in records], np.mean),
        "median_rest_direction_free_error": _nanstat(
            [r.rest_direction_free_error for r in records], np.median),
        "median_rest_max_error": _nanstat([r.rest_max_error for r in records], np.median),
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


def suite_tasks(suite: str, split: str = "test", grasp: str = "head",
                limit: int | None = None) -> list[Any]:
    """The tasks of a named suite's split, in order, whatever its kind: ``linear-K``, designed,
    cord, peg and route suites (each task's ``options()`` are its ``reset`` options).

    Args:
        suite: The suite's name.
        split: ``"train"`` or ``"test"``.
        grasp: ``"head"`` (``DLOEndpoint-v0``) or ``"both"`` (``DLODualEndpoint-v0``).
        limit: Only the first ``limit`` tasks.
    """
    check_suite(suite)
    for names, load in _suite_kinds():
        if suite in names:
            return list(load(suite, split, grasp=grasp, limit=limit))
    raise AssertionError(f"no loader for suite {suite!r}")


def _suite_kinds() -> tuple[tuple[Any, Callable[..., Any]], ...]:
    """Every kind of named suite: (its names, its loader)."""
    from dlo_env.cord_suites import CORD_SUITES, load_cord_suite
    from dlo_env.designed_suites import DESIGNED_SUITES, load_designed_suite
    from dlo_env.peg_suites import PEG_SUITES, ROUTE_SUITES, load_peg_suite, load_route_suite
    from dlo_env.tasks import SUITES, load_suite

    return ((SUITES, load_suite), (DESIGNED_SUITES, load_designed_suite),
            (CORD_SUITES, load_cord_suite), (PEG_SUITES, load_peg_suite),
            (ROUTE_SUITES, load_route_suite))


def suite_names() -> list[str]:
    """Every named suite: linear, designed, cord, peg and route suites, in that order."""
    return [name for names, _ in _suite_kinds() for name in names]


def check_suite(suite: str) -> str:
    """``suite`` if it names a suite of any kind, else a one-line ``ValueError`` listing them."""
    every = suite_names()
    if suite not in every:
        raise InputError(f"suite must be one of {', '.join(every)}, got {suite!r}")
    return suite


def _episode_options(
    difficulty: int | None, suite: str | None, split: str, episodes: int, grasp: str
) -> list[dict[str, Any] | None]:
    if suite is not None:
        made = suite_tasks(suite, split, grasp, limit=episodes)
        if len(made) < episodes:
            raise InputError(f"first + episodes must be at most the {len(made)} tasks of "
                             f"suite {suite!r} split {split!r}, got {episodes}")
        return [t.options() for t in made]
    return [None if difficulty is None else {"difficulty": difficulty}] * episodes


def _run_episode(
    policy: Policy, env: Any, index: int, reset_seed: int | None, options: dict[str, Any] | None,
    difficulty: int | None, fidelity: bool,
) -> tuple[EpisodeRecord, FidelityProfile | None, np.ndarray, np.ndarray]:
    """One episode of ``policy`` in ``env``: its record, the first plan's fidelity profile, the
    goal and the shape the cord rests in after the last step."""
    from dlo_bench.fidelity import transition_fidelity
    from dlo_env.shapes import error as shape_error

    base = env.unwrapped
    n = base.params.n_points
    obs, info = env.reset(seed=reset_seed, options=options)
    start = np.asarray(obs["achieved_goal"], dtype=np.float32).reshape(n, 2)
    goal = np.asarray(obs["desired_goal"], dtype=np.float32).reshape(n, 2)
    task_seed = int(info.get("task_seed", -1))
    task_difficulty = int(info.get("difficulty", difficulty or 0))
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
    rest = base.settled_metrics()
    planned = isinstance(policy, PlanningPolicy)
    stats = policy.episode_stats() if planned else EpisodeStats(seconds=seconds)
    plan = stats.first_plan
    fid = plan_final = fid_max = travel = start_inv = math.nan
    profile = None
    if plan is not None:
        travel = plan.path_length
        start_inv = float(plan.stats.get("start_inversion_error", math.nan))
        if fidelity:
            result = transition_fidelity(plan, start, params=base.cord.params,
                                         pegs=base.cord.pegs, peg_radius=base.peg_radius,
                                         max_step=base.max_step)
            fid, plan_final, fid_max = result.mean_error, result.final_error, result.max_error
            profile = FidelityProfile(index, result.errors, result.travel, result.move)
    record = EpisodeRecord(
        episode=index,
        seed=-1 if reset_seed is None else int(reset_seed),
        task_seed=task_seed,
        difficulty=task_difficulty,
        success=bool(info["is_success"]),
        start_error=float(shape_error(start, goal)),
        final_error=float(info["error"]),
        final_max_error=float(info["max_error"]),
        rest_error=float(rest["error"]),
        rest_direction_free_error=float(rest["direction_free_error"]),
        rest_max_error=float(rest["max_error"]),
        steps=steps,
        seconds=seconds,
        planning_seconds=stats.seconds,
        plans=stats.plans,
        planning_failures=stats.failures,
        fidelity=fid,
        plan_final_error=plan_final,
        fidelity_max=fid_max,
        plan_moves=len(plan.nodes) - 1 if plan is not None else 0,
        plan_travel=travel,
        start_inversion_error=start_inv,
        goal_inversion_error=stats.goal_inversion_error,
    )
    return record, profile, goal, rest["shape"]


def task_env_kwargs(difficulty: int | None = None, suite: str | None = None
                    ) -> dict[str, Any]:
    """``gym.make`` keyword arguments of the environment a suite's (or a difficulty's) tasks
    run in: episodes of ``dlo_env.tasks.suite_max_steps`` / ``difficulty_max_steps`` steps;
    a designed suite's drawn goals get ``DESIGNED_MAX_STEPS`` steps, are scored
    direction-free and run on the suite's cord (``params``; the agents built on the
    environment are told it)."""
    from dlo_env.cord_suites import CORD_SUITES
    from dlo_env.designed_suites import DESIGNED_MAX_STEPS, DESIGNED_SUITES, designed_suite_cord
    from dlo_env.peg_suites import PEGGED_SUITES, SUITE_MAX_PEGS
    from dlo_env.tasks import difficulty_max_steps, suite_max_steps

    if suite is not None:
        check_suite(suite)
    if suite in PEGGED_SUITES:
        return {"max_episode_steps": difficulty_max_steps(PEGGED_SUITES[suite]),
                "max_pegs": SUITE_MAX_PEGS}
    if suite in DESIGNED_SUITES:
        cord = designed_suite_cord(suite)
        return {"max_episode_steps": DESIGNED_MAX_STEPS, "success_metric": "direction_free_error",
                **({} if cord is None else {"params": cord})}
    if suite in CORD_SUITES:
        return {"max_episode_steps": difficulty_max_steps(CORD_SUITES[suite])}
    if suite is not None:
        return {"max_episode_steps": suite_max_steps(suite)}
    if difficulty is not None:
        return {"max_episode_steps": difficulty_max_steps(difficulty)}
    return {}


def _check_evaluate_arguments(policy: Policy, episodes: int, first: int,
                              difficulty: int | None, suite: str | None) -> None:
    """Refuse ``evaluate``'s arguments that cannot make an evaluation."""
    if not isinstance(policy, Policy):
        raise InputError(f"policy must have a predict() method, got {type(policy).__name__}")
    if not (isinstance(episodes, int) and episodes >= 1):
        raise InputError(f"episodes must be an int >= 1, got {episodes!r}")
    if not (isinstance(first, int) and not isinstance(first, bool) and first >= 0):
        raise InputError(f"first must be an int >= 0 (an episode index), got {first!r}")
    if difficulty is not None and suite is not None:
        raise InputError("give difficulty or suite, not both")


def _evaluation_env(env: gym.Env | str, env_kwargs: dict[str, Any] | None,
                    difficulty: int | None, suite: str | None) -> tuple[gym.Env, bool]:
    """The environment ``evaluate`` runs in, and whether it made it (from an id; then it
    closes it)."""
    import gymnasium as gym

    import dlo_env  # noqa: F401  (registers the environments)

    if isinstance(env, str):
        return gym.make(env, **{**task_env_kwargs(difficulty, suite), **(env_kwargs or {})}), True
    if not isinstance(env, gym.Env):
        raise InputError(f"env must be a dlo_env environment or its id, got "
                         f"{type(env).__name__}")
    if env_kwargs:
        raise InputError("env_kwargs apply to an environment made from an id; got an "
                         "environment and env_kwargs")
    if getattr(env.spec, "max_episode_steps", None) is None:
        raise InputError("env must end its episodes: make it with gym.make (which adds the "
                         "registered TimeLimit) or wrap it in gymnasium.wrappers.TimeLimit")
    return env, False


def _run_episodes(
    policy: Policy, env: gym.Env, options: list[dict[str, Any] | None], first: int,
    seed: int | None, difficulty: int | None, fidelity: bool, bar: Any,
) -> tuple[list[EpisodeRecord], list[FidelityProfile], list[np.ndarray], list[np.ndarray]]:
    """Episodes ``first, first + 1, ...`` of ``policy``, one per task option (reset seeds
    ``seed + index``; None: the tasks carry their own): the records, the first plans'
    fidelity profiles, the goals and the shapes at rest. ``bar`` (None: none) counts them."""
    records, profiles, goals, rest_shapes = [], [], [], []
    for i, opts in enumerate(options, first):
        reset_seed = None if seed is None else seed + i
        record, profile, goal, rest = _run_episode(policy, env, i, reset_seed, opts,
                                                   difficulty, fidelity)
        records.append(record)
        goals.append(goal)
        rest_shapes.append(rest)
        if profile is not None:
            profiles.append(profile)
        if bar is not None:
            bar.update(1)
            bar.set_postfix_str(f"success {np.mean([r.success for r in records]):.0%}")
    if bar is not None:
        bar.close()
    return records, profiles, goals, rest_shapes


@renamed_argument("env_id", "env")
def evaluate(
    policy: Policy,
    env: gym.Env | str = DEFAULT_ENV,
    difficulty: int | None = None,
    suite: str | None = None,
    episodes: int = DEFAULT_EPISODES,
    seed: int = 0,
    *,
    split: str = "test",
    agent: str = "",
    fidelity: bool = True,
    env_kwargs: dict[str, Any] | None = None,
    progress: bool = False,
    first: int = 0,
) -> Evaluation:
    """Run ``episodes`` episodes of ``policy`` and score them against the real cord.

    Args:
        policy: A ``planners.interfaces.Policy`` (SB3's ``predict``).
        env: A ``dlo_env`` goal environment, or its id (as ``build_agent`` takes an
            environment): an environment given is used as it is and left open; one made from
            an id (with ``env_kwargs``; with a ``suite`` or ``difficulty``, episodes of
            ``dlo_env.tasks.suite_max_steps`` or ``difficulty_max_steps`` steps unless
            ``env_kwargs`` says otherwise) is closed at the end. ``env_id`` is its deprecated
            name.
        difficulty: Straight moves per task (the environment's default if None).
        suite: A named suite (``linear-1``, ..., a designed one such as ``shapes-curves``,
            scored direction-free in an environment made from an id, or a cord suite such as
            ``cords-3``, each task on its own cord) instead of
            ``difficulty``: its fixed tasks.
        episodes: Number of episodes.
        seed: Episode ``i`` resets with seed ``seed + i`` (random tasks).
        split: The suite's split, ``"test"`` or ``"train"``.
        agent: Name of the agent in the summary.
        fidelity: Compute the transition fidelity of plans (one extra simulation per episode).
        env_kwargs: Extra keyword arguments of ``gym.make``.
        progress: Show a tqdm progress bar.
        first: Index of the first episode: run episodes ``first`` .. ``first + episodes - 1``
            (the suite's tasks of those indices, or reset seeds ``seed + index``), numbered so
            in the records. An episode depends only on its task, the seed and the policy's
            settings, so the episodes of one evaluation can run in parts, in any order.

    Returns:
        The records and their summary.
    """
    _check_evaluate_arguments(policy, episodes, first, difficulty, suite)
    env, owned = _evaluation_env(env, env_kwargs, difficulty, suite)
    spec = getattr(env.unwrapped, "spec", None)
    env_id = spec.id if spec is not None else type(env.unwrapped).__name__
    try:
        if isinstance(policy, PlanningPolicy):
            policy.check_env(env)
        options = _episode_options(difficulty, suite, split, first + episodes,
                                   env.unwrapped.grasp)[first:]
        bar = progress_bar(episodes, agent or "evaluate", "episode") if progress else None
        records, profiles, goals, rest_shapes = _run_episodes(
            policy, env, options, first, seed if suite is None else None, difficulty, fidelity,
            bar)
    finally:
        if owned:
            env.close()
    summary = summarise(records, agent=agent, env_id=env_id)
    summary["suite"] = suite or ""
    summary["divergence"] = divergence(profiles)
    return Evaluation(records=records, summary=summary, profiles=profiles, goals=goals,
                      rest_shapes=rest_shapes)
