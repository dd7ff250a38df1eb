"""The comparison benchmark: every agent on the test suites of both environments, one table.

``run_benchmark`` evaluates the registered agents (``dlo_bench.agents.AGENTS``) on the test
split of the suites ``linear-1`` to ``linear-5`` in ``DLOEndpoint-v0`` and ``linear-1`` to
``linear-3`` in ``DLODualEndpoint-v0``, and the long horizons ``linear-8`` and ``linear-10`` in
both (fixed tasks, so every agent sees the same episodes) with
:func:`dlo_bench.evaluation.evaluate`, once at each success threshold (2, 1 and 0.5 cm, judged
on the cord at rest; the planners take their stopping rules from it). The designed suites
(``shapes-curves``: drawn goals, scored direction-free) run once, at the headline threshold,
in every environment; their rows add the errors per curve family beside the reference errors
of :mod:`dlo_bench.reference`. The ``cords`` section runs the cord suites (``cords-3``: each
task on a held-out cord the agents are not told, :mod:`dlo_env.cord_suites`) with the agents
of ``CORD_AGENTS``, at the headline threshold. The ``pegs`` section runs the peg suites
(``pegs-K``: goals made by K moves among pegs; ``route-K``: goals that need the cord routed
around a peg, :mod:`dlo_env.peg_suites`) with the agents of ``PEG_AGENTS`` in an environment
that observes the pegs, at the headline threshold; its RL agents are those trained there
(``dlo baseline --max-pegs``). An agent that does not act
in an environment, or whose model is missing, gets a row that says so, never silently none.
Every row states the agent's sample cost: the data its model or policy was trained on. Every
finished (agent, environment, suite, threshold) cell is written at once, so an interrupted
run resumes; :func:`dlo_bench.benchmark_report.write_results` then writes the table (Markdown),
the rows (JSON) and a bar chart (PNG), all atomically.

Every cell records what made it: the git commit of the code (:func:`code_version`, ``+dirty``
with uncommitted changes to tracked files) and the run (one invocation, :func:`new_run_id`) that
timed it, so the report compares planning times only between cells of one run.
"""

from __future__ import annotations

import functools
import json
import math
import os
import subprocess
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dlo_bench.agents import (
    AGENTS,
    DUAL_ENDPOINT,
    ENDPOINT,
    SB3_PREFIX,
    agent_spec,
)
from dlo_bench.evaluation import (
    EpisodeRecord,
    Evaluation,
    FidelityProfile,
    divergence,
    evaluate,
    suite_tasks,
    summarise,
    task_env_kwargs,
)
from dlo_bench.loaded_agent import LoadedAgent, load_agent, load_shape_model
from dlo_bench.report import HEADLINE_THRESHOLD, json_ready, threshold_label, write_evaluation
from dlo_env.cord_suites import CORD_SUITES
from dlo_env.core.atomic import file_digest
from dlo_env.designed_suites import DESIGNED_SUITES
from dlo_env.envs import ENVIRONMENTS
from dlo_env.peg_suites import PEGGED_SUITES
from dlo_env.tasks import SPLIT_SIZES, SUITES
from planners.interfaces import Policy, ShapeSurrogate
from planners.policy import DEFAULT_REPLAN_EVERY

#: The test suite of every difficulty: ``linear-K`` holds tasks of K straight moves.
SUITE_OF_DIFFICULTY = {difficulty: name for name, difficulty in SUITES.items()}
#: The difficulties each environment is benchmarked on by default.
DEFAULT_DIFFICULTIES = {ENDPOINT: (1, 2, 3, 4, 5, 8, 10), DUAL_ENDPOINT: (1, 2, 3, 8, 10)}
#: Success thresholds every cell runs at, metres (judged at rest): one evaluation each.
THRESHOLDS = (0.02, 0.01, 0.005)
#: The designed suites the benchmark runs in every environment.
DEFAULT_DESIGNED = ("shapes-curves",)
#: The cord suites of the ``cords`` section (tasks on held-out cords the agents are not told).
DEFAULT_CORDS = ("cords-3",)
#: The agents of the ``cords`` section, in table order.
CORD_AGENTS = ("straight-line", "latent-mpc", "latent-mpc-adaptive", "physics-mpc",
               "physics-mpc-true-cord", "sac-her-cords")
#: The environments of the ``cords`` section.
CORD_ENVS = (ENDPOINT,)
#: The suites of the ``pegs`` section (goals made among pegs; goals that need routing).
DEFAULT_PEGS = tuple(PEGGED_SUITES)
#: The agents of the ``pegs`` section, in table order: every agent of the main table.
PEG_AGENTS = tuple(name for name, spec in AGENTS.items() if not spec.cords)
#: The environments of the ``pegs`` section.
PEG_ENVS = (ENDPOINT, DUAL_ENDPOINT)
#: Episodes of every cell in ``--quick`` runs.
QUICK_EPISODES = 2
#: Subfolder of the output folder holding one CSV/JSON of episodes per cell.
CELLS_DIR = "results_episodes"


@dataclass(frozen=True)
class BenchmarkConfig:
    """What the benchmark runs; the defaults are those of the published table.

    Attributes:
        agents: Agent names (keys of ``dlo_bench.agents.AGENTS``), in table order.
        envs: Environment ids, in table order.
        difficulties: Difficulties of every environment, each the test split of its suite
            ``linear-K``; None: ``DEFAULT_DIFFICULTIES`` of each environment; empty: no
            linear cells.
        thresholds: Success thresholds, metres: every linear cell runs once at each (the
            environment's ``success_threshold``).
        designed: Designed suites (``dlo_env.designed_suites``) run in every environment,
            once, at the headline threshold (or the first of ``thresholds`` without it).
        cords: Cord suites (``dlo_env.cord_suites``: every task on its own held-out cord, not
            told to the agents) of the ``cords`` section, run at the designed threshold (none
            by default here; ``dlo benchmark`` runs ``DEFAULT_CORDS``).
        cord_agents: The agents of the ``cords`` section, when it runs (the agents marked
            ``cords`` in the registry run only there).
        cord_envs: The environments of the ``cords`` section.
        pegs: Suites with pegs (``dlo_env.peg_suites``: ``pegs-K``, ``route-K``) of the
            ``pegs`` section, run at the designed threshold in an environment observing
            ``dlo_env.peg_suites.SUITE_MAX_PEGS`` pegs (none by default here; ``dlo benchmark`` runs
            ``DEFAULT_PEGS``).
        peg_agents: The agents of the ``pegs`` section, when it runs.
        peg_envs: The environments of the ``pegs`` section.
        episodes: Episodes per cell (the first tasks of the split; the split has 50).
        seed: Seed of the planners' sampling.
        baselines: Folder with one ``dlo baseline`` output folder per RL agent and environment
            (``ppo/``, ``sac-her/``, ``bc/`` for ``DLOEndpoint-v0``; ``ppo-dual-endpoint/``...
            for ``DLODualEndpoint-v0``); None: the shipped ones in ``dlo_bench/pretrained``.
        model: Shape model file or folder of the latent-tree agents (None: the shipped one).
        transition_model: Transition model file or folder of latent-mpc and latent-tree-kino
            (None: the shipped one).
        cords_transition_model: Transition model of several cords of the agents marked
            ``cords`` (latent-mpc-adaptive; None: the shipped ``transition-cords.pt``).
        pegs_transition_model: Transition model of the agents of the ``pegs`` section (a
            model that sees pegs, ``dlo train --stage transition --peg-reach``; None: the
            shipped ``transition-pegs.pt``).
        replan_every: Steps between replans of ``latent-tree-closed``.
        max_seconds: Time budget of one latent-tree plan (None: the planner's default).
        fidelity: Compute the transition fidelity of each first latent-tree plan.
    """

    agents: tuple[str, ...] = tuple(name for name, spec in AGENTS.items() if not spec.cords)
    envs: tuple[str, ...] = tuple(DEFAULT_DIFFICULTIES)
    difficulties: tuple[int, ...] | None = None
    thresholds: tuple[float, ...] = THRESHOLDS
    designed: tuple[str, ...] = DEFAULT_DESIGNED
    cords: tuple[str, ...] = ()
    cord_agents: tuple[str, ...] = CORD_AGENTS
    cord_envs: tuple[str, ...] = CORD_ENVS
    pegs: tuple[str, ...] = ()
    peg_agents: tuple[str, ...] = PEG_AGENTS
    peg_envs: tuple[str, ...] = PEG_ENVS
    episodes: int = SPLIT_SIZES["test"]
    seed: int = 0
    baselines: str | None = None
    model: str | None = None
    transition_model: str | None = None
    cords_transition_model: str | None = None
    pegs_transition_model: str | None = None
    replan_every: int = DEFAULT_REPLAN_EVERY
    max_seconds: float | None = None
    fidelity: bool = True

    def __post_init__(self) -> None:
        unknown = [a for a in self.agents if not registered(a)]
        if unknown or not (self.agents or self.cord_agents or self.peg_agents):
            raise ValueError(f"agents must be a tuple of {tuple(AGENTS)} or sb3:PATH (with "
                             f"cord_agents and peg_agents, not all empty), got {self.agents!r}")
        cords_only = [a for a in self.agents if agent_spec(a).cords]
        if cords_only:
            raise ValueError(f"agents must not name agents of the cords section only "
                             f"({', '.join(cords_only)}): give them as cord_agents")
        if any(not registered(a) for a in self.cord_agents):
            raise ValueError(f"cord_agents must be some of {tuple(AGENTS)}, "
                             f"got {self.cord_agents!r}")
        if any(not registered(a) or agent_spec(a).cords for a in self.peg_agents):
            raise ValueError(f"peg_agents must be some of {PEG_AGENTS}, "
                             f"got {self.peg_agents!r}")
        bad_envs = [e for e in (*self.envs, *self.cord_envs, *self.peg_envs)
                    if e not in ENVIRONMENTS]
        if bad_envs or not self.envs:
            raise ValueError(f"envs, cord_envs and peg_envs must be some of "
                             f"{tuple(ENVIRONMENTS)} (envs not empty), got {self.envs!r}, "
                             f"{self.cord_envs!r} and {self.peg_envs!r}")
        if any(c not in CORD_SUITES for c in self.cords) or len(set(self.cords)) < len(
                self.cords):
            raise ValueError(f"cords must be distinct suites of {tuple(CORD_SUITES)}, "
                             f"got {self.cords!r}")
        if any(p not in PEGGED_SUITES for p in self.pegs) or len(set(self.pegs)) < len(
                self.pegs):
            raise ValueError(f"pegs must be distinct suites of {tuple(PEGGED_SUITES)}, "
                             f"got {self.pegs!r}")
        if self.difficulties is not None:
            bad = [d for d in self.difficulties if d not in SUITE_OF_DIFFICULTY]
            if bad:
                raise ValueError(f"difficulties must be some of {tuple(SUITE_OF_DIFFICULTY)} "
                                 f"(or none: no linear cells), got {self.difficulties!r}")
        ok = [isinstance(t, (int, float)) and not isinstance(t, bool) and math.isfinite(t)
              and t > 0 for t in self.thresholds]
        if not self.thresholds or not all(ok) or len(set(self.thresholds)) < len(ok):
            raise ValueError(f"thresholds must be distinct numbers > 0 (metres), "
                             f"got {self.thresholds!r}")
        if any(d not in DESIGNED_SUITES for d in self.designed) or len(
                set(self.designed)) < len(self.designed):
            raise ValueError(f"designed must be distinct suites of {tuple(DESIGNED_SUITES)}, "
                             f"got {self.designed!r}")
        if not self.cells():
            raise ValueError("the benchmark has no cell to run: give difficulties, designed, "
                             "cord or peg suites (with agents of their sections)")
        size = SPLIT_SIZES["test"]
        if not (isinstance(self.episodes, int) and 1 <= self.episodes <= size):
            raise ValueError(f"episodes must be an int in 1..{size} (the test split), "
                             f"got {self.episodes!r}")

    def cells(self, agent: str | None = None) -> list[tuple[str, str, float]]:
        """``(env_id, suite, threshold)`` of every cell (of ``agent``'s, when given), in table
        order: the linear suites at every threshold, the designed ones at the headline
        threshold, then the cord suites of the ``cords`` section and the peg suites of the
        ``pegs`` section."""
        cells: list[tuple[str, str, float]] = []
        if (agent is None and self.agents) or agent in self.agents:
            cells += [(env, SUITE_OF_DIFFICULTY[d], t) for t in self.thresholds
                      for env in self.envs
                      for d in (self.difficulties if self.difficulties is not None
                                else DEFAULT_DIFFICULTIES.get(env, (1, 2, 3)))]
            cells += [(env, suite, self.designed_threshold) for suite in self.designed
                      for env in self.envs]
        if (agent is None and self.cord_agents) or agent in self.cord_agents:
            # (no cells without cord suites)
            cells += [(env, suite, self.designed_threshold) for suite in self.cords
                      for env in self.cord_envs]
        if (agent is None and self.peg_agents) or agent in self.peg_agents:
            cells += [(env, suite, self.designed_threshold) for suite in self.pegs
                      for env in self.peg_envs]
        return cells

    @property
    def all_agents(self) -> tuple[str, ...]:
        """Every agent of the run, in table order: ``agents``, then the rest of
        ``cord_agents`` (when cord suites run) and of ``peg_agents`` (when peg suites run)."""
        return tuple(dict.fromkeys((*self.agents, *(self.cord_agents if self.cords else ()),
                                    *(self.peg_agents if self.pegs else ()))))

    @property
    def designed_threshold(self) -> float:
        """The threshold the designed cells run at."""
        return HEADLINE_THRESHOLD if HEADLINE_THRESHOLD in self.thresholds else self.thresholds[0]


def env_label(env_id: str) -> str:
    """The short name of an environment in tables and file names (``endpoint``...)."""
    return ENVIRONMENTS[env_id][1]


def suite_label(suite: str) -> str:
    """A suite's short name in tables and file names: ``d3`` for ``linear-3``, designed suites
    by name."""
    return f"d{SUITES[suite]}" if suite in SUITES else suite


def registered(name: str) -> bool:
    """Whether the benchmark can run agent ``name``: a key of ``AGENTS``, or ``sb3:PATH``."""
    return name in AGENTS or (name.startswith(SB3_PREFIX) and len(name) > len(SB3_PREFIX))


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
    for name in ("agents", "envs", "difficulties", "thresholds", "designed", "cords",
                 "cord_agents", "cord_envs", "cords_transition_model", "pegs", "peg_agents",
                 "peg_envs", "pegs_transition_model"):
        key.pop(name)  # the model file used is in the key by its digest
    where = {"difficulty": SUITES[suite]} if suite in SUITES else {"suite": suite}
    return {**key, "agent": agent.name, "env_id": env_id, **where, "threshold": threshold,
            "model_digest": "+".join(file_digest(m) for m in agent.models),
            "settings": agent.settings}


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
        "models": list(agent.models),
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


def _load_cell(path: Path, key: dict[str, Any], *, full: bool = False
               ) -> tuple[Evaluation, dict[str, Any]] | None:
    """A cell (or part of one) written by an earlier run with the same key: its evaluation and
    run facts. ``full``: with the fidelity profiles, goals and rest shapes a part keeps."""
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


#: What a cell records of the run that made it: the code's commit, the run, the machine.
RUN_FACTS = ("commit", "run", "machine")


def machine_label() -> str:
    """This machine in a few words, recorded with every cell it times: the processor's model
    (``/proc/cpuinfo`` where there is one) and the CPUs, ``Intel(R) Xeon(R) ... x 2 CPUs``."""
    import platform

    model = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model or platform.processor() or platform.machine()} x {os.cpu_count()} CPUs"


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


#: The folder holding the code's packages: a git checkout's root when run from a clone.
CODE_ROOT = Path(__file__).resolve().parent.parent


@dataclass(frozen=True)
class CodeState:
    """The git checkout the code runs from.

    Attributes:
        root: The checkout's root.
        commit: The short commit of ``HEAD``.
        changed: Tracked files with uncommitted changes (staged or not), relative to ``root``;
            untracked files (``runs/``, ``data/``) do not count.
    """

    root: Path
    commit: str
    changed: tuple[str, ...]

    @property
    def version(self) -> str:
        """The commit, ``+dirty`` with uncommitted changes to tracked files."""
        return self.commit + ("+dirty" if self.changed else "")


def code_state(root: str | os.PathLike | None = None) -> CodeState | None:
    """The git checkout whose root is ``root`` (None: :data:`CODE_ROOT`), or None when it is not
    the root of one (an installed package; a package inside some other repository's tree)."""
    folder = Path(root).resolve() if root is not None else CODE_ROOT

    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=folder, check=True, capture_output=True,
                              text=True, timeout=30).stdout

    try:
        if Path(git("rev-parse", "--show-toplevel").strip()).resolve() != folder:
            return None
        commit = git("rev-parse", "--short", "HEAD").strip()
        status = git("status", "--porcelain", "--untracked-files=no", "-z")
    except (OSError, subprocess.SubprocessError):  # no git, not a checkout, no commit yet
        return None
    # -z: "XY PATH\0", a rename adds "ORIGINAL\0"; paths are not quoted.
    entries = status.split("\0")
    changed, k = [], 0
    while k < len(entries):
        entry = entries[k]
        if entry:
            changed.append(entry[3:])
            if entry[0] in "RC":
                k += 1
        k += 1
    return CodeState(folder, commit, tuple(changed))


def code_version() -> str:
    """``git`` commit of the code (``+dirty`` with uncommitted changes to tracked files), ""
    outside a checkout of its own."""
    state = code_state()
    return state.version if state is not None else ""


def new_run_id() -> str:
    """A new run's id: its UTC start time and a random suffix (``20261125T055614Z-3f2a``)."""
    import secrets

    return time.strftime("%Y%m%dT%H%M%SZ", time.gmtime()) + "-" + secrets.token_hex(2)


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


def absolute_paths(config: BenchmarkConfig) -> BenchmarkConfig:
    """``config`` with its model and baseline paths made absolute."""
    from dataclasses import replace

    fields_ = ("model", "transition_model", "cords_transition_model", "pegs_transition_model",
               "baselines")
    return replace(config, **{f: str(Path(getattr(config, f)).resolve()) for f in fields_
                              if getattr(config, f)})


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
