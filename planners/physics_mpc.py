"""Physics-in-the-loop planning: the simulator itself as the model (the paper's foil).

``PhysicsMPCPolicy`` plans with the cross-entropy method (CEM) over short sequences of straight
moves of the grasped end(s). Every candidate is scored by simulating it on a fresh copy of the
cord (``Cord.reset`` from the observed shape, then the moves, then a short settle) and measuring
the shape error to the goal. The best plan is executed for ``replan_every`` environment steps,
then the policy plans again from the observed cord (model-predictive control). It is accurate by
construction, up to the cord's state not being fully observed (velocities are dropped), and slow:
each candidate costs a full simulation. That cost is what the latent-tree planner avoids.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from dlo_env.checks import positive_ints
from dlo_env.cord import Cord, CordParams
from dlo_env.shapes import error
from planners.interfaces import EpisodeStats, Observation


@dataclass(frozen=True)
class PhysicsMPCConfig:
    """Parameters of the CEM planner; defaults are the ones the benchmark reports.

    Attributes:
        moves: Straight moves per candidate plan.
        samples: Candidates simulated per CEM iteration.
        elites: Best candidates the next sampling distribution is fitted to.
        iterations: CEM iterations per planning call.
        init_std: Initial standard deviation of every displacement coordinate, metres.
        max_move: Largest displacement of one move, metres (per end).
        settle_periods: Control periods simulated with the grippers still before scoring.
        replan_every: Environment steps executed between planning calls.
        seed: Seed of the sampling.
    """

    moves: int = 2
    samples: int = 32
    elites: int = 6
    iterations: int = 3
    init_std: float = 0.08
    max_move: float = 0.4
    settle_periods: int = 2
    replan_every: int = 8
    seed: int = 0

    def __post_init__(self) -> None:
        positive_ints(self, "moves", "samples", "elites", "iterations", "replan_every")
        if self.elites > self.samples:
            raise ValueError(
                f"PhysicsMPCConfig.elites must be <= samples ({self.samples}), got {self.elites}"
            )
        if not (self.init_std > 0 and self.max_move > 0):
            raise ValueError("PhysicsMPCConfig.init_std and max_move must be > 0")


@dataclass
class PhysicsMPCStats:
    """What the policy did in the current episode."""

    plans: int = 0
    rollouts: int = 0
    seconds: float = 0.0
    predicted_errors: list[float] = field(default_factory=list)


class PhysicsMPCPolicy:
    """CEM model-predictive control with the cord simulator as the model.

    Same interface as Stable-Baselines3 models and ``planners.PlannerPolicy``: ``predict`` maps a
    Dict observation of a ``dlo_env`` environment to an action in ``[-1, 1]^d``.

    Args:
        params: The cord's parameters (those of the environment it acts in).
        grasp: ``"head"`` for ``DLOEndpoint-v0``, ``"both"`` for ``DLODualEndpoint-v0``.
        max_step: The environment's ``max_step`` (metres per unit action).
        success_threshold: Shape error (metres) below which the policy holds still.
        config: CEM parameters.
    """

    def __init__(
        self,
        params: CordParams | None = None,
        grasp: str = "head",
        max_step: float = 0.02,
        success_threshold: float = 0.02,
        config: PhysicsMPCConfig | None = None,
    ) -> None:
        if grasp not in ("head", "both"):
            raise ValueError(f"grasp must be 'head' or 'both', got {grasp!r}")
        if not max_step > 0:
            raise ValueError(f"max_step must be > 0, got {max_step!r}")
        self.params = params if params is not None else CordParams()
        self.grasp = grasp
        self.ends = ("head",) if grasp == "head" else ("head", "tail")
        self.max_step = float(max_step)
        self.success_threshold = float(success_threshold)
        self.config = config if config is not None else PhysicsMPCConfig()
        self._cord = Cord(self.params, grasp=grasp)  # the model: reset for every candidate
        self._rng = np.random.default_rng(self.config.seed)
        self.reset()

    @classmethod
    def for_env(cls, env: object, config: PhysicsMPCConfig | None = None) -> PhysicsMPCPolicy:
        """Build the policy matching a ``dlo_env`` environment (wrapped or not)."""
        base = getattr(env, "unwrapped", env)
        return cls(
            params=base.params,
            grasp=base.cord.grasp,
            max_step=base.max_step,
            success_threshold=base.success_threshold,
            config=config,
        )

    def check_env(self, env: object) -> None:
        """Raise ``ValueError`` unless the environment's cord, grasp and step match this policy."""
        base = getattr(env, "unwrapped", env)
        if (base.params, base.cord.grasp, base.max_step) != (self.params, self.grasp,
                                                              self.max_step):
            raise ValueError(
                f"the physics planner was made for grasp {self.grasp!r}, max_step "
                f"{self.max_step} m and {self.params}, but the environment has grasp "
                f"{base.cord.grasp!r}, max_step {base.max_step} m and {base.params}: build it "
                "with PhysicsMPCPolicy.for_env(env)"
            )

    def episode_stats(self) -> EpisodeStats:
        """Planning calls and seconds of this episode (it never fails to return a plan)."""
        return EpisodeStats(plans=self.stats.plans, seconds=self.stats.seconds)

    def reset(self) -> None:
        """Forget the current plan and the episode's statistics."""
        self._queue: list[np.ndarray] = []
        self._mean: np.ndarray | None = None
        self.stats = PhysicsMPCStats()

    # ------------------------------------------------------------------ planning
    def _rollout(self, shape: np.ndarray, plan: np.ndarray) -> float:
        """Simulate one candidate ``(moves, ends, 2)`` from ``shape``; return the final shape."""
        cord = self._cord
        cord.reset(shape)
        for move in plan:
            cord.move(**{end: move[i] for i, end in enumerate(self.ends)})
        cord.wait(self.config.settle_periods)
        return cord.shape

    def _score(self, shape: np.ndarray, goal: np.ndarray, candidates: np.ndarray) -> np.ndarray:
        """Errors ``(S,)`` to ``goal`` of candidate plans ``(S, moves, ends, 2)`` from ``shape``:
        the one place where planning on another model differs."""
        return np.array([error(self._rollout(shape, c), goal) for c in candidates])

    def plan(self, shape: np.ndarray, goal: np.ndarray) -> tuple[np.ndarray, float]:
        """CEM over straight-move sequences from ``shape`` towards ``goal``.

        Returns:
            The best plan ``(moves, ends, 2)`` of displacements (metres) and its simulated error.
        """
        cfg = self.config
        t0 = time.perf_counter()
        dims = (cfg.moves, len(self.ends), 2)
        if self._mean is None:
            # Warm start: every end goes straight to where the goal has it, in equal moves.
            ends = [shape[0], shape[-1]][: len(self.ends)]
            goal_ends = [goal[0], goal[-1]][: len(self.ends)]
            straight = np.stack([g - s for s, g in zip(ends, goal_ends)]) / cfg.moves
            mean = np.broadcast_to(straight, dims).astype(np.float64)
        else:
            mean = self._mean
        std = np.full(dims, cfg.init_std)
        best_plan, best_err = mean.copy(), math.inf
        for _ in range(cfg.iterations):
            candidates = mean + std * self._rng.standard_normal((cfg.samples,) + dims)
            candidates[0] = mean  # always re-score the current mean
            norms = np.linalg.norm(candidates, axis=-1, keepdims=True)
            candidates *= np.minimum(1.0, cfg.max_move / np.maximum(norms, 1e-12))
            errors = self._score(shape, goal, candidates)
            self.stats.rollouts += cfg.samples
            order = np.argsort(errors)
            if errors[order[0]] < best_err:
                best_err, best_plan = float(errors[order[0]]), candidates[order[0]].copy()
            elite = candidates[order[: cfg.elites]]
            mean, std = elite.mean(axis=0), elite.std(axis=0) + 1e-3
        # Next call starts from the rest of this plan (shifted), the usual MPC warm start.
        self._mean = np.concatenate([best_plan[1:], np.zeros((1,) + dims[1:])])
        self.stats.plans += 1
        self.stats.seconds += time.perf_counter() - t0
        self.stats.predicted_errors.append(best_err)
        return best_plan, best_err

    def _execute(self, plan: np.ndarray) -> list[np.ndarray]:
        """The actions run before the next planning call: ``replan_every`` steps of the plan."""
        return self._actions(plan)[: self.config.replan_every]

    def _actions(self, plan: np.ndarray) -> list[np.ndarray]:
        """Split each move into equal actions no longer than ``max_step`` (as the env runs them)."""
        actions = []
        for move in plan:
            longest = float(np.linalg.norm(move, axis=-1).max())
            k = max(1, math.ceil(longest / self.max_step - 1e-9))
            step = (move / (k * self.max_step)).reshape(-1).astype(np.float32)
            actions.extend([step] * k)
        return actions

    # ------------------------------------------------------------------ policy
    def predict(
        self,
        observation: Observation,
        state: object = None,
        episode_start: np.ndarray | None = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, object]:
        """Next action for one observation (SB3 signature; unbatched or batch of one)."""
        if episode_start is not None and bool(np.asarray(episode_start).reshape(-1)[0]):
            self.reset()
        n = self.params.n_points
        achieved = np.asarray(observation["achieved_goal"], dtype=np.float64)
        desired = np.asarray(observation["desired_goal"], dtype=np.float64)
        batched = achieved.ndim == 2
        shape = achieved.reshape(-1, n, 2)[0]
        goal = desired.reshape(-1, n, 2)[0]
        action_dim = 2 * len(self.ends)
        if error(shape, goal) <= self.success_threshold:
            action = np.zeros(action_dim, dtype=np.float32)
        else:
            if not self._queue:
                plan, _ = self.plan(shape, goal)
                self._queue = self._execute(plan)
            action = self._queue.pop(0) if self._queue else np.zeros(action_dim, np.float32)
        action = np.clip(action, -1.0, 1.0)
        return (action[None] if batched else action), state
