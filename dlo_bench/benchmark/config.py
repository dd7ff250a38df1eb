"""What the benchmark runs: the default suites, agents, environments and success thresholds of
its sections, in :class:`BenchmarkConfig`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from dlo_bench.agents import AGENTS, DUAL_ENDPOINT, ENDPOINT, SB3_PREFIX, agent_spec
from dlo_bench.report import HEADLINE_THRESHOLD
from dlo_env.cord_suites import CORD_SUITES
from dlo_env.designed_suites import DESIGNED_SUITES
from dlo_env.envs import ENVIRONMENTS
from dlo_env.errors import InputError
from dlo_env.peg_suites import PEGGED_SUITES
from dlo_env.tasks import SPLIT_SIZES, SUITES
from planners.policy import DEFAULT_REPLAN_EVERY

#: The test suite of every difficulty: ``linear-K`` holds tasks of K straight moves.
SUITE_OF_DIFFICULTY = {difficulty: name for name, difficulty in SUITES.items()}
#: The difficulties each environment is benchmarked on by default.
DEFAULT_DIFFICULTIES = {ENDPOINT: (1, 2, 3, 4, 5, 8, 10), DUAL_ENDPOINT: (1, 2, 3, 8, 10)}
#: Success thresholds every cell runs at, metres (judged at rest): one evaluation each.
THRESHOLDS = (0.02, 0.01, 0.005)
#: The designed suites the benchmark runs in every environment.
DEFAULT_DESIGNED = ("shapes-curves", "shapes-letters")
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
#: ``--quick``, a smoke run of every agent and section in a few minutes on two cores: one
#: episode of each cell, at the headline threshold, of linear-1 and of one suite per section.
QUICK_EPISODES = 1
QUICK_DIFFICULTIES = (1,)
QUICK_SECTIONS = {"designed": ("shapes-curves",), "cords": ("cords-1",), "pegs": ("pegs-1",)}
#: ``--quick``'s environments of the designed suites (physics-mpc takes ~100 s per drawn goal).
QUICK_DESIGNED_ENVS = (ENDPOINT,)


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
        designed: Designed suites (``dlo_env.designed_suites``) run in every environment of
            ``designed_envs``, once, at the headline threshold (or the first of ``thresholds``
            without it).
        designed_envs: The environments of the designed suites (None: ``envs``).
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
            model that sees pegs, ``dlo train transition --peg-reach``; None: the
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
    designed_envs: tuple[str, ...] | None = None
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
            raise InputError(f"agents must be a tuple of {tuple(AGENTS)} or sb3:PATH (with "
                             f"cord_agents and peg_agents, not all empty), got {self.agents!r}",
                             field="agents")
        cords_only = [a for a in self.agents if agent_spec(a).cords]
        if cords_only:
            raise InputError(f"agents must not name agents of the cords section only "
                             f"({', '.join(cords_only)}): give them as cord_agents", field="agents")
        if any(not registered(a) for a in self.cord_agents):
            raise InputError(f"cord_agents must be some of {tuple(AGENTS)}, "
                             f"got {self.cord_agents!r}", field="cord_agents")
        if any(not registered(a) or agent_spec(a).cords for a in self.peg_agents):
            raise InputError(f"peg_agents must be some of {PEG_AGENTS}, "
                             f"got {self.peg_agents!r}", field="peg_agents")
        bad_envs = [e for e in (*self.envs, *self.cord_envs, *self.peg_envs,
                                *(self.designed_envs or ())) if e not in ENVIRONMENTS]
        if bad_envs or not self.envs:
            raise InputError(f"envs, designed_envs, cord_envs and peg_envs must be some of "
                             f"{tuple(ENVIRONMENTS)} (envs not empty), got {self.envs!r}, "
                             f"{self.designed_envs!r}, {self.cord_envs!r} and "
                             f"{self.peg_envs!r}",
                             field=("envs", "designed_envs", "cord_envs", "peg_envs"))
        unset = [e for e in self.envs if e not in DEFAULT_DIFFICULTIES]
        if self.difficulties is None and unset:
            raise InputError(f"envs {unset!r} have no default difficulties "
                             "(DEFAULT_DIFFICULTIES): give difficulties", field="difficulties")
        if any(c not in CORD_SUITES for c in self.cords) or len(set(self.cords)) < len(
                self.cords):
            raise InputError(f"cords must be distinct suites of {tuple(CORD_SUITES)}, "
                             f"got {self.cords!r}", field="cords")
        if any(p not in PEGGED_SUITES for p in self.pegs) or len(set(self.pegs)) < len(
                self.pegs):
            raise InputError(f"pegs must be distinct suites of {tuple(PEGGED_SUITES)}, "
                             f"got {self.pegs!r}", field="pegs")
        if self.difficulties is not None:
            bad = [d for d in self.difficulties if d not in SUITE_OF_DIFFICULTY]
            if bad:
                raise InputError(f"difficulties must be some of {tuple(SUITE_OF_DIFFICULTY)} "
                                 f"(or none: no linear cells), got {self.difficulties!r}",
                                 field="difficulties")
        ok = [isinstance(t, (int, float)) and not isinstance(t, bool) and math.isfinite(t)
              and t > 0 for t in self.thresholds]
        if not self.thresholds or not all(ok) or len(set(self.thresholds)) < len(ok):
            raise InputError(f"thresholds must be distinct numbers > 0 (metres; none may repeat), "
                             f"got {self.thresholds!r}", field="thresholds")
        if any(d not in DESIGNED_SUITES for d in self.designed) or len(
                set(self.designed)) < len(self.designed):
            raise InputError(f"designed must be distinct suites of {tuple(DESIGNED_SUITES)}, "
                             f"got {self.designed!r}", field="designed")
        if not self.cells():
            raise InputError("the benchmark has no cell to run: give difficulties, designed, "
                             "cord or peg suites (with agents of their sections)")
        size = SPLIT_SIZES["test"]
        if not (isinstance(self.episodes, int) and 1 <= self.episodes <= size):
            raise InputError(f"episodes must be an int in 1..{size} (the test split), "
                             f"got {self.episodes!r}", field="episodes")

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
                                else DEFAULT_DIFFICULTIES[env])]
            cells += [(env, suite, self.designed_threshold) for suite in self.designed
                      for env in (self.envs if self.designed_envs is None
                                  else self.designed_envs)]
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


def registered(name: str) -> bool:
    """Whether the benchmark can run agent ``name``: a key of ``AGENTS``, or ``sb3:PATH``."""
    return name in AGENTS or (name.startswith(SB3_PREFIX) and len(name) > len(SB3_PREFIX))


def absolute_paths(config: BenchmarkConfig) -> BenchmarkConfig:
    """``config`` with its model and baseline paths made absolute."""
    from dataclasses import replace

    fields_ = ("model", "transition_model", "cords_transition_model", "pegs_transition_model",
               "baselines")
    return replace(config, **{f: str(Path(getattr(config, f)).resolve()) for f in fields_
                              if getattr(config, f)})
