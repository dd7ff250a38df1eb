"""A benchmark cell, an agent on one environment, suite and threshold: its file name, the key a
saved cell is reused by, its parts of episodes, and loading and merging them.
"""

from __future__ import annotations

import math
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from dlo_bench.benchmark.config import SUITE_OF_DIFFICULTY, BenchmarkConfig
from dlo_bench.benchmark.provenance import RUN_FACTS
from dlo_bench.cell_store import LEGACY_SUFFIX, cell_path, find_cell, read_cell, write_cell
from dlo_bench.evaluation import EpisodeRecord, Evaluation, FidelityProfile, divergence, summarise
from dlo_bench.loaded_agent import LoadedAgent
from dlo_bench.report import evaluation_data, json_ready, threshold_label
from dlo_env.core.atomic import file_digest
from dlo_env.envs import ENVIRONMENTS
from dlo_env.errors import InputError
from dlo_env.tasks import SUITES

#: Subfolder of the output folder holding one file of episodes per cell (``.npz``,
#: :mod:`dlo_bench.cell_store`).
CELLS_DIR = "results_episodes"


def env_label(env_id: str) -> str:
    """The short name of an environment in tables and file names (``endpoint``...)."""
    return ENVIRONMENTS[env_id][1]


def suite_label(suite: str) -> str:
    """A suite's short name in tables and file names: ``d3`` for ``linear-3``, designed suites
    by name."""
    return f"d{SUITES[suite]}" if suite in SUITES else suite


def agent_label(name: str) -> str:
    """An agent's name in file names: itself, or ``sb3:PATH`` with every character but
    letters, digits, ``.`` and ``_`` as ``-`` (``sb3-runs-baseline-ppo``)."""
    return "".join(c if c.isalnum() or c in "._-" else "-" for c in name)


def cell_name(agent: str, env_id: str, suite: str, threshold: float) -> str:
    """A cell's file name: ``latent-mpc-endpoint-d3-1cm``, ``physics-mpc-dual-endpoint-
    shapes-curves-1cm``."""
    return (f"{agent_label(agent)}-{env_label(env_id)}-{suite_label(suite)}-"
            f"{threshold_label(threshold, '')}")


def cell_key(config: BenchmarkConfig, agent: LoadedAgent, env_id: str,
             suite: str, threshold: float) -> dict[str, Any]:
    """What a cell's result depends on; a saved cell is reused only when its key matches."""
    key = asdict(config)
    for name in ("agents", "envs", "difficulties", "thresholds", "designed", "designed_envs",
                 "cords",
                 "cord_agents", "cord_envs", "cords_transition_model", "pegs", "peg_agents",
                 "peg_envs", "pegs_transition_model"):
        key.pop(name)  # the model file used is in the key by its digest
    where = {"difficulty": SUITES[suite]} if suite in SUITES else {"suite": suite}
    return {**key, "agent": agent.name, "env_id": env_id, **where, "threshold": threshold,
            "model_digest": "+".join(file_digest(m) for m in agent.models),
            "settings": agent.settings}


def _load_cell(folder: Path, name: str, key: dict[str, Any], *, full: bool = False
               ) -> tuple[Evaluation, dict[str, Any]] | None:
    """Cell (or part) ``name`` of ``folder``, written by an earlier run with the same key: its
    evaluation and run facts (None: no such cell, another key or an unreadable file).
    ``full``: with the fidelity profiles, goals and rest shapes a part keeps."""
    from dataclasses import fields

    path = find_cell(folder, name)
    if path is None:
        return None
    try:
        data = read_cell(path)
    except InputError:
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
    facts = {"wall_seconds": data.get("wall_seconds"),
             **{k: data.get(k, "") for k in RUN_FACTS}}
    summary = summarise(records, agent=key["agent"], env_id=key["env_id"])
    summary["suite"] = key.get("suite") or SUITE_OF_DIFFICULTY.get(key.get("difficulty"), "")
    if not full:
        return Evaluation(records, summary), facts
    profiles = [FidelityProfile(p["episode"], *(np.asarray(p[k], dtype=float)
                                                for k in ("errors", "travel", "move")))
                for p in data.get("fidelity_profiles", [])]
    shapes = [[np.asarray(x, dtype=np.float32) for x in data.get(k, [])]
              for k in ("goals", "rest")]
    return Evaluation(records, summary, profiles, *shapes), facts


def write_cell_of(evaluation: Evaluation, folder: Path, name: str, extra: dict[str, Any]
                  ) -> Path:
    """Write cell (or part) ``name`` of ``folder`` (:mod:`dlo_bench.cell_store`), replacing
    the files an older version wrote for it (``.json`` and ``.csv``)."""
    path = write_cell(cell_path(folder, name), evaluation_data(evaluation, extra))
    for suffix in (LEGACY_SUFFIX, ".csv"):
        (folder / f"{name}{suffix}").unlink(missing_ok=True)
    return path


#: Subfolder of ``CELLS_DIR`` holding the finished parts of cells not finished yet.
PARTS_DIR = "parts"


def part_name(cell: str, first: int, count: int) -> str:
    """A part's file name: ``physics-mpc-endpoint-d3-1cm.episodes-10-19``."""
    return f"{cell}.episodes-{first}-{first + count - 1}"


def split_episodes(episodes: int, part: int | None) -> list[tuple[int, int]]:
    """``(first, count)`` of the parts of a cell of ``episodes`` episodes, ``part`` episodes
    each (None: one part, the whole cell)."""
    size = episodes if part is None else part
    return [(a, min(size, episodes - a)) for a in range(0, episodes, size)]


def merge_parts(parts: list[tuple[Evaluation, dict[str, Any]]], agent: str, env_id: str
                ) -> tuple[Evaluation, dict[str, Any]]:
    """One evaluation of a cell's parts (in episode order) and its facts: the summed wall
    time, and the commits and runs of the parts (``+``-joined when they differ, so planning
    times of a cell whose parts ran in several runs are not compared)."""
    if len(parts) == 1:
        return parts[0]
    records = [r for e, _ in parts for r in e.records]
    profiles = [p for e, _ in parts for p in e.profiles]
    summary = summarise(records, agent=agent, env_id=env_id)
    summary["suite"] = parts[0][0].summary.get("suite", "")
    summary["divergence"] = divergence(profiles)
    evaluation = Evaluation(records, summary, profiles, [g for e, _ in parts for g in e.goals],
                            [r for e, _ in parts for r in e.rest_shapes])
    walls = [f["wall_seconds"] for _, f in parts]
    facts = {"wall_seconds": None if None in walls else float(sum(walls)),
             **{k: "+".join(dict.fromkeys(f.get(k, "") for _, f in parts)) for k in RUN_FACTS}}
    return evaluation, facts
