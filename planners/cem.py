"""The cross-entropy method over straight moves: the planner shared by physics-mpc and latent-mpc.

``CEMPolicy`` plans sequences of ``moves`` straight moves of the held end(s) with the
cross-entropy method (CEM), warm-started from the rest of the previous plan, executes part of
the best plan and plans again from the observed cord (model-predictive control). What a
candidate plan does to the cord is the one thing a subclass decides (``_score``), and what it
executes before planning again (``_execute``): the simulator in ``PhysicsMPCPolicy``, the
learned transition model in ``LatentMPCPolicy``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, fields

import numpy as np

from dlo_env.cord import CordParams
from dlo_env.core.checks import fractions, non_negative, non_negative_ints, positive, positive_ints
from dlo_env.errors import InputError
from dlo_env.shapes import SUCCESS_METRICS
from dlo_env.tasks import GRASP_ENDS, split_move
from planners.episodic_policy import EpisodicPolicy
from planners.interfaces import EpisodeStats
from planners.observation import CordObservation

#: ``metadata`` of a config field added after the benchmark's cells were recorded, whose default
#: keeps the planner as it was: ``settings_repr`` leaves it out at that default, so the cells
#: stay valid.
LATER = {"later": True}


def settings_repr(config: object) -> str:
    """``repr`` of a dataclass ``config`` without its ``LATER`` fields at their defaults (the
    ``repr`` of a config before those fields existed); ``repr`` of anything else."""
    if not hasattr(config, "__dataclass_fields__"):
        return repr(config)
    shown = [f"{f.name}={getattr(config, f.name)!r}" for f in fields(config)  # type: ignore
             if f.repr and not (f.metadata.get("later") and getattr(config, f.name) == f.default)]
    return f"{type(config).__qualname__}({', '.join(shown)})"


@dataclass(frozen=True)
class CEMConfig:
    """The search budget of a CEM planner over straight moves.

    Attributes:
        moves: Straight moves per candidate plan (the horizon).
        samples: Candidates scored per CEM iteration.
        elites: Best candidates the next sampling distribution is fitted to.
        iterations: CEM iterations per planning call (at most).
        init_std: Initial standard deviation of every displacement coordinate, metres.
        focus: Sampling focused near the goal: a plan's initial standard deviation is
            ``focus`` times the cord's current error, between ``min_std`` and ``init_std``
            (0: always ``init_std``).
        min_std: The smallest initial standard deviation with ``focus``, metres.
        max_move: Largest displacement of one move, metres (per end).
        far_moves: The horizon while the cord is farther than ``far_error`` from the goal
            (0: always ``moves``): far goals need long paths, near ones precise short plans.
        far_error: Error (metres, the policy's success metric) beyond which ``far_moves``
            applies.
        far_grasps: The grasps ``far_moves`` applies to.
        stop_fraction: Stop iterating once the best predicted error is at most this fraction
            of the policy's ``success_threshold`` (the environment's; 0: always run every
            iteration).
        offer_straight: Score, in every iteration, the plan that moves every held end straight
            to where the goal has it (in as few equal moves as ``max_move`` allows, then still;
            with direction-free scoring, to either end of the goal) beside the samples: a warm
            start drops it after the first plan.
        seed: Seed of the sampling.
    """

    moves: int = 2
    samples: int = 32
    elites: int = 6
    iterations: int = 3
    init_std: float = 0.08
    focus: float = 0.0
    min_std: float = 0.005
    max_move: float = 0.4
    far_moves: int = 0
    far_error: float = 0.03
    far_grasps: tuple[str, ...] = tuple(GRASP_ENDS)
    stop_fraction: float = 0.0
    offer_straight: bool = field(default=False, metadata=LATER)
    seed: int = 0

    def __post_init__(self) -> None:
        name = type(self).__name__
        positive_ints(self, "moves", "samples", "elites", "iterations")
        non_negative_ints(self, "far_moves")
        positive(self, "init_std", "max_move", "min_std", "far_error")
        non_negative(self, "focus")
        fractions(self, "stop_fraction", closed_low=True)
        if not (isinstance(self.far_grasps, tuple) and set(self.far_grasps) <= set(GRASP_ENDS)):
            raise InputError(f"{name}.far_grasps must be a tuple of {tuple(GRASP_ENDS)}, "
                             f"got {self.far_grasps!r}")
        if self.min_std > self.init_std:
            raise InputError(f"{name}.min_std must be <= init_std ({self.init_std}), "
                             f"got {self.min_std}")
        if self.elites > self.samples:
            raise InputError(f"{name}.elites must be <= samples ({self.samples}), "
                             f"got {self.elites}")


@dataclass
class CEMStats:
    """What the policy did in the current episode."""

    plans: int = 0
    rollouts: int = 0
    seconds: float = 0.0
    predicted_errors: list[float] = field(default_factory=list)


class CEMPolicy(EpisodicPolicy):
    """CEM model-predictive control over straight moves; subclasses give the model.

    Same interface as Stable-Baselines3 models and ``planners.PlannerPolicy``: ``predict`` maps a
    Dict observation of a ``dlo_env`` environment (or a vector env's batch) to an action in
    ``[-1, 1]^d``; a new episode is noticed without ``episode_start``
    (``planners.episodic_policy.EpisodicPolicy``).

    Args:
        params: The cord's parameters (those of the environment it acts in).
        grasp: The held end(s): ``"head"`` (``DLOEndpoint-v0``), ``"tail"`` or ``"both"``
            (``DLODualEndpoint-v0``).
        max_step: The environment's ``max_step`` (metres per unit action).
        success_threshold: The environment's success threshold, metres: the policy holds still
            within it, and stops a plan's iterations at ``config.stop_fraction`` of it.
        config: CEM budget.
        success_metric: The environment's ``success_metric``: ``"error"``, or
            ``"direction_free_error"`` (plans are scored against the goal in either order).
    """

    def __init__(self, params: CordParams | None, grasp: str, max_step: float,
                 success_threshold: float, config: CEMConfig, *,
                 success_metric: str = "error") -> None:
        if success_metric not in SUCCESS_METRICS:
            raise InputError(f"success_metric must be one of {tuple(SUCCESS_METRICS)}, got "
                             f"{success_metric!r}")
        self.success_metric = success_metric
        self._distance = SUCCESS_METRICS[success_metric]
        if grasp not in GRASP_ENDS:
            raise InputError(f"grasp must be one of {tuple(GRASP_ENDS)}, got {grasp!r}")
        if not max_step > 0:
            raise InputError(f"max_step must be > 0, got {max_step!r}")
        self.params = params if params is not None else CordParams()
        self.grasp = grasp
        self.ends = GRASP_ENDS[grasp]
        self.max_step = float(max_step)
        self.success_threshold = float(success_threshold)
        self.config = config
        self.n_points = self.params.n_points
        self.reset()

    def _check_threshold(self, base: object) -> None:
        """Raise ``ValueError`` unless the environment's ``success_threshold`` is the policy's
        (it holds still within it and stops planning at a fraction of it)."""
        threshold = float(getattr(base, "success_threshold", self.success_threshold))
        metric = getattr(base, "success_metric", self.success_metric)
        if abs(threshold - self.success_threshold) > 1e-12 or metric != self.success_metric:
            raise InputError(
                f"the policy was built for success_threshold={self.success_threshold} m and "
                f"success_metric={self.success_metric!r}, but the environment has "
                f"success_threshold={threshold} m and success_metric={metric!r}: build it with "
                f"{type(self).__name__}.for_env(env)")

    def episode_stats(self) -> EpisodeStats:
        """Planning calls and seconds of this episode (it never fails to return a plan)."""
        return EpisodeStats(plans=self.stats.plans, seconds=self.stats.seconds)

    def reset(self) -> None:
        """Forget the current plan and the episode's statistics, and restart the sampling from
        ``config.seed``: an episode's plans depend on its task and the seed only, not on the
        episodes before it (so episodes and cells can run in any order or process)."""
        self._queue: list[np.ndarray] = []
        self._mean: np.ndarray | None = None
        self._rng = np.random.default_rng(self.config.seed)
        self.stats = CEMStats()

    # ------------------------------------------------------------------ to override
    def _score(self, shape: np.ndarray, goal: np.ndarray, candidates: np.ndarray) -> np.ndarray:
        """Errors ``(S,)`` to ``goal`` of candidate plans ``(S, moves, ends, 2)`` from ``shape``."""
        raise NotImplementedError

    def _execute(self, plan: np.ndarray) -> list[np.ndarray]:
        """The actions of ``plan`` run before the next planning call."""
        raise NotImplementedError

    # ------------------------------------------------------------------ planning
    def _end_points(self, shape: np.ndarray) -> np.ndarray:
        """``(ends, 2)`` positions of the held ends."""
        return np.stack([shape[0] if end == "head" else shape[-1] for end in self.ends])

    def plan(self, shape: np.ndarray, goal: np.ndarray) -> tuple[np.ndarray, float]:
        """CEM over straight-move sequences from ``shape`` towards ``goal``.

        Returns:
            The best plan ``(moves, ends, 2)`` of displacements (metres) and its scored error.
        """
        cfg = self.config
        t0 = time.perf_counter()
        moves = self.horizon(shape, goal)
        dims = (moves, len(self.ends), 2)
        if self._mean is None:
            # Warm start: every end goes straight to where the goal has it, in equal moves.
            straight = (self._end_points(goal) - self._end_points(shape)) / moves
            mean = np.broadcast_to(straight, dims).astype(np.float64)
        else:  # the rest of the previous plan, cut or padded with still moves to this horizon
            mean = np.zeros(dims)
            kept = min(moves, len(self._mean))
            mean[:kept] = self._mean[:kept]
        std = np.full(dims, cfg.init_std)
        if cfg.focus > 0:
            near = cfg.focus * float(self._distance(shape, goal))
            std[:] = min(cfg.init_std, max(cfg.min_std, near))
        offers = (self._straight_plans(shape, goal, moves) if cfg.offer_straight
                  else np.empty((0,) + dims))[:cfg.samples - 1]
        kept = max(1, self.keep)  # the best plans scored so far, for _choose
        pool, pool_errors = np.empty((0,) + dims), np.empty(0)
        for _ in range(cfg.iterations):
            candidates = mean + std * self._rng.standard_normal((cfg.samples,) + dims)
            candidates[0] = mean  # always re-score the current mean
            candidates[1:1 + len(offers)] = offers
            norms = np.linalg.norm(candidates, axis=-1, keepdims=True)
            candidates *= np.minimum(1.0, cfg.max_move / np.maximum(norms, 1e-12))
            errors = self._score(shape, goal, candidates)
            self.stats.rollouts += cfg.samples
            order = np.argsort(errors)
            pool = np.concatenate([pool, candidates[order[:kept]]])
            pool_errors = np.concatenate([pool_errors, errors[order[:kept]]])
            best = np.argsort(pool_errors, kind="stable")[:kept]
            pool, pool_errors = pool[best], pool_errors[best]
            if pool_errors[0] <= cfg.stop_fraction * self.success_threshold:
                break
            elite = candidates[order[: cfg.elites]]
            mean, std = elite.mean(axis=0), elite.std(axis=0) + 1e-3
        best_plan, best_err = self._choose(shape, goal, pool, pool_errors)
        if best_err > cfg.stop_fraction * self.success_threshold:
            best_plan, best_err = self._refine(shape, goal, best_plan, best_err)
        # Next call starts from the rest of this plan (shifted), the usual MPC warm start.
        self._mean = np.concatenate([best_plan[1:], np.zeros((1,) + dims[1:])])
        self.stats.plans += 1
        self.stats.seconds += time.perf_counter() - t0
        self.stats.predicted_errors.append(best_err)
        return best_plan, best_err

    #: How many of the best plans scored ``_choose`` picks from (1: the best one).
    keep = 1

    def _choose(self, shape: np.ndarray, goal: np.ndarray, plans: np.ndarray,
                errors: np.ndarray) -> tuple[np.ndarray, float]:
        """The plan to execute among the ``keep`` best scored ``plans`` (best first) and its
        error: the best one (a subclass may check them further)."""
        return plans[0].copy(), float(errors[0])

    def _refine(self, shape: np.ndarray, goal: np.ndarray, plan: np.ndarray, error: float
                ) -> tuple[np.ndarray, float]:
        """The plan to execute, given the search's ``plan`` and its ``error`` where that is not
        predicted within ``stop_fraction`` of the threshold: ``plan`` itself (a subclass may
        improve it)."""
        return plan, error

    def _straight_plans(self, shape: np.ndarray, goal: np.ndarray, moves: int) -> np.ndarray:
        """``(k, moves, ends, 2)``: the held end(s) straight to the goal's in as few equal
        moves as ``max_move`` allows (at most ``moves``), then still; towards the reversed goal
        too when plans are scored direction-free."""
        goals = [goal] + ([goal[::-1]] if self.success_metric == "direction_free_error" else [])
        plans = np.zeros((len(goals), moves, len(self.ends), 2))
        for i, g in enumerate(goals):
            span = self._end_points(g) - self._end_points(shape)
            k = min(moves, max(1, math.ceil(float(np.linalg.norm(span, axis=-1).max())
                                            / self.config.max_move)))
            plans[i, :k] = span / k
        return plans

    def horizon(self, shape: np.ndarray, goal: np.ndarray) -> int:
        """Moves of the plan from ``shape``: ``config.far_moves`` while farther than
        ``config.far_error`` from ``goal`` (when set, for ``config.far_grasps``), else
        ``config.moves``."""
        cfg = self.config
        if (cfg.far_moves and self.grasp in cfg.far_grasps
                and float(self._distance(shape, goal)) > cfg.far_error):
            return cfg.far_moves
        return cfg.moves

    def _actions(self, plan: np.ndarray) -> list[np.ndarray]:
        """Each move as the environments carry it out: ``split_move``'s equal actions."""
        return [action for move in plan for action in split_move(move, self.max_step)]

    # ------------------------------------------------------------------ policy
    def _act(self, obs: CordObservation) -> np.ndarray:
        """Hold still within ``success_threshold`` of the goal; else the queued plan's next
        action, planning again from the observed cord when the queue is empty."""
        shape = obs.shape.astype(np.float64)
        goal = obs.goal.astype(np.float64)
        action_dim = 2 * len(self.ends)
        if self._distance(shape, goal) <= self.success_threshold:
            return np.zeros(action_dim, dtype=np.float32)
        if not self._queue:
            plan, _ = self.plan(shape, goal)
            self._queue = self._execute(plan)
        return self._queue.pop(0) if self._queue else np.zeros(action_dim, np.float32)
