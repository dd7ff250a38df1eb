"""The row of a cell in the results: its summary, or why its agent is missing; a cord suite's
per cord and a designed suite's per curve family, beside the reference errors.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from dlo_bench.benchmark.cells import env_label, suite_label
from dlo_bench.benchmark.provenance import RUN_FACTS, model_label
from dlo_bench.evaluation import EpisodeRecord, Evaluation, suite_tasks
from dlo_bench.loaded_agent import LoadedAgent
from dlo_env.cord_suites import CORD_SUITES
from dlo_env.designed_suites import DESIGNED_SUITES
from dlo_env.envs import ENVIRONMENTS
from dlo_env.tasks import SUITES


def row_of(agent: LoadedAgent, env_id: str, suite: str, threshold: float,
           evaluation: Evaluation | None, episodes: int) -> dict[str, Any]:
    """One row of the results: the summary of a cell, or a row saying the agent is missing.

    A designed suite's row scores the cord at rest direction-free (``median_rest_error``) and
    adds ``designed``: per curve family and over all, the agent's median error, the
    reference's, and the shares within 1 and 2 cm and within ``NEAR_REFERENCE`` of the
    reference (:func:`designed_summary`).
    """
    row: dict[str, Any] = {
        "agent": agent.name,
        "env": env_label(env_id),
        "env_id": env_id,
        "difficulty": SUITES.get(suite),
        "cell": suite_label(suite),
        "threshold": threshold,
        "suite": f"{suite}/test",
        "status": "ok" if not agent.missing else "missing" if agent.applicable else "n/a",
        "note": agent.missing,
        "episodes": episodes if evaluation is not None else 0,
        "success_rate": None,
        "median_error": None,
        "mean_error": None,
        "median_rest_error": None,
        "seconds_per_episode": None,
        "median_seconds_per_episode": None,
        "total_seconds": None,
        "mean_steps": None,
        "planning_failures": None,
        "mean_fidelity": None,
        "training_env_steps": agent.training_env_steps,
        "sample_cost": agent.sample_cost,
        "models": [model_label(m) for m in agent.models],
        "wall_seconds": None,
        **dict.fromkeys(RUN_FACTS, ""),
    }
    if evaluation is not None:
        records, s = evaluation.records, evaluation.summary
        seconds = [r.planning_seconds for r in records]
        row.update(
            success_rate=s["success_rate"],
            median_error=s["median_final_error"],
            mean_error=s["mean_final_error"],
            median_rest_error=s["median_rest_error"],
            seconds_per_episode=float(np.mean(seconds)),
            median_seconds_per_episode=float(np.median(seconds)),
            total_seconds=float(np.sum(seconds)),
            mean_steps=s["mean_steps"],
            planning_failures=s["planning_failures"],
            mean_fidelity=s["mean_fidelity"],
        )
        if suite in DESIGNED_SUITES:
            row["median_rest_error"] = s["median_rest_direction_free_error"]
            row["designed"] = designed_summary(suite, env_id, records)
        if suite in CORD_SUITES:
            row["cords"] = cords_summary(records)
    return row


def cords_summary(records: list[EpisodeRecord]) -> dict[str, dict[str, float]]:
    """Per held-out cord of a cord suite's test split (episode ``i`` runs on
    ``TEST_CORDS[test_cord_index(i)]``; keys its index as text): episodes, success rate and
    median error at rest, metres."""
    from dlo_env.cord_suites import test_cord_index
    from dlo_env.randomize import TEST_CORDS

    out: dict[str, dict[str, float]] = {}
    for i in range(len(TEST_CORDS)):
        group = [r for r in records if test_cord_index(r.episode) == i]
        if group:
            out[str(i)] = {"episodes": len(group),
                           "success_rate": float(np.mean([r.success for r in group])),
                           "median_rest_error": float(np.median([r.rest_error for r in group]))}
    return out


@functools.lru_cache(maxsize=16)
def designed_tasks(suite: str, env_id: str, count: int) -> tuple[tuple[int, str], ...]:
    """``(seed, family)`` of the first ``count`` test tasks of a designed suite in ``env_id``
    (made once per process: each goal is relaxed in the simulator)."""
    return tuple((t.seed, t.family)
                 for t in suite_tasks(suite, "test", ENVIRONMENTS[env_id][0], limit=count))


@functools.lru_cache(maxsize=16)
def peg_tasks(suite: str, env_id: str, count: int) -> tuple[Any, ...]:
    """The first ``count`` test tasks (``dlo_env.tasks.Task``, with their pegs) of a suite with
    pegs in ``env_id`` (made once per process)."""
    return tuple(suite_tasks(suite, "test", ENVIRONMENTS[env_id][0], limit=count))


#: An agent is near the reference on a designed task when its error at rest is within this
#: many metres of the reference error (the issue's 0.5 cm).
NEAR_REFERENCE = 0.005


def designed_summary(suite: str, env_id: str, records: list[EpisodeRecord]
                     ) -> dict[str, dict[str, Any]]:
    """Per curve family (and ``"all"``) of a designed cell: ``episodes``, the agent's
    ``median_error`` (direction-free, at rest), the shares ``within_1cm`` and ``within_2cm``,
    and, over the ``reference_tasks`` episodes whose task has a reference error,
    ``near_reference`` (the agent within ``NEAR_REFERENCE`` of it) and the reference's
    ``reference_median``, ``reference_within_1cm`` and ``reference_within_2cm`` (None where no
    task has one).

    Episode ``i`` is the ``i``-th test task of the suite (``evaluate``'s order)."""
    from dlo_bench.reference import load_references

    references = load_references(suite, env_id)
    groups: dict[str, list[tuple[float, float | None]]] = {"all": []}
    for (seed, family), record in zip(designed_tasks(suite, env_id, len(records)), records):
        ref = references.get(seed)
        pair = (record.rest_direction_free_error, None if ref is None else ref["error"])
        groups.setdefault(family, []).append(pair)
        groups["all"].append(pair)

    def share(values: np.ndarray, limit: float) -> float:
        return float(np.mean(values <= limit))

    out: dict[str, dict[str, Any]] = {}
    for family, pairs in groups.items():
        errors = np.array([p[0] for p in pairs], dtype=float)
        entry: dict[str, Any] = {"episodes": len(pairs),
                                 "median_error": float(np.nanmedian(errors)),
                                 "within_1cm": share(errors, 0.01),
                                 "within_2cm": share(errors, 0.02),
                                 "reference_tasks": 0, "near_reference": None,
                                 "reference_median": None, "reference_within_1cm": None,
                                 "reference_within_2cm": None}
        known = np.array([p[1] is not None for p in pairs])
        if known.any():
            refs = np.array([p[1] for p in pairs if p[1] is not None], dtype=float)
            entry.update(reference_tasks=int(known.sum()),
                         near_reference=float(np.mean(errors[known] <= refs + NEAR_REFERENCE)),
                         reference_median=float(np.median(refs)),
                         reference_within_1cm=share(refs, 0.01),
                         reference_within_2cm=share(refs, 0.02))
        out[family] = entry
    return out
