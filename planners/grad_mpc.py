"""grad-mpc: straight-move plans optimised by gradient steps through the learned cord.

latent-mpc samples plans and keeps the best (the cross-entropy method). grad-mpc descends: a
batch of candidate plans (the straight move to the goal's end positions and random ones around
it) is rolled out through ``latent_model.cord_dynamics.CordDynamics``, the torch step of the
transition model, and Adam moves every candidate's displacements down the gradient of its
final error to the goal. The best candidate is executed like latent-mpc's (its first move, then
zero actions while the cord comes to rest), and the policy plans again from the observed cord.
With ``cem_iterations`` the gradient's best plan also seeds a short CEM search (both together).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dlo_env.core.checks import non_negative_ints, positive, positive_ints
from planners.gradient_search import clip_moves, descend
from planners.latent_mpc import LatentMPCConfig, LatentMPCPolicy


@dataclass(frozen=True)
class GradMPCConfig(LatentMPCConfig):
    """The gradient search of grad-mpc (the rest as ``LatentMPCConfig``).

    Attributes:
        samples: Candidate plans descended together (the first is the straight move, or the
            rest of the previous plan).
        grad_steps: Adam steps per planning call (at most: it stops once a candidate is
            predicted within ``stop_fraction`` of the success threshold).
        learning_rate: Adam's step size, metres.
        elites: Best candidates a CEM iteration after the gradient steps is fitted to.
        cem_iterations: CEM iterations after the gradient steps, from its best plan (0: none).
        projection_iterations: Steps of the projection onto rest-length segments in every
            predicted move (``CordDynamics``' ``inextensible_iterations``; 0: none, faster).
    """

    samples: int = 16
    elites: int = 8
    grad_steps: int = 40
    learning_rate: float = 0.01
    cem_iterations: int = 0
    projection_iterations: int = 0
    # latent-mpc's polish of a sampled plan; grad-mpc descends every plan (unused, unshown).
    polish_steps: int = field(default=0, repr=False)
    polish_samples: int = field(default=8, repr=False)
    polish_std: float = field(default=0.01, repr=False)
    polish_rate: float = field(default=0.01, repr=False)

    def __post_init__(self) -> None:
        super().__post_init__()
        positive_ints(self, "grad_steps")
        non_negative_ints(self, "cem_iterations", "projection_iterations")
        positive(self, "learning_rate")


class GradMPCPolicy(LatentMPCPolicy):
    """Model-predictive control by gradient descent on straight-move plans through the
    differentiable transition model; built and checked like :class:`LatentMPCPolicy`.

    Args:
        model: A ``latent_model.TransitionModel`` of the environment's cord.
        grasp: The held end(s).
        success_threshold: The environment's success threshold, metres.
        config: The search budget.
        cord: As ``LatentMPCPolicy``: the cord told to a model of several cords, which its
            differentiable step then predicts (None: the model's own).
    """

    def __init__(self, model: Any, grasp: str = "head", success_threshold: float = 0.02,
                 config: GradMPCConfig | None = None, *,
                 success_metric: str = "error", cord: Any = None) -> None:
        from latent_model.cord_dynamics import CordDynamics

        super().__init__(model, grasp, success_threshold,
                         config if config is not None else GradMPCConfig(),
                         success_metric=success_metric, cord=cord)
        self.dynamics = CordDynamics(model, grasp, params=self.cord,
                                     inextensible_iterations=self.config.projection_iterations)

    def plan(self, shape: np.ndarray, goal: np.ndarray) -> tuple[np.ndarray, float]:
        """Gradient descent on ``config.samples`` plans from ``shape`` towards ``goal``.

        Returns:
            The best plan ``(moves, ends, 2)`` (metres) and its predicted error.
        """

        cfg = self.config
        t0 = time.perf_counter()
        moves = self.horizon(shape, goal)
        dims = (moves, len(self.ends), 2)
        if self._mean is None:  # the straight move to the goal's end positions, in equal parts
            straight = (self._end_points(goal) - self._end_points(shape)) / moves
            mean = np.broadcast_to(straight, dims).astype(np.float64)
        else:
            mean = np.zeros(dims)
            kept = min(moves, len(self._mean))
            mean[:kept] = self._mean[:kept]
        std = cfg.init_std
        if cfg.focus > 0:
            std = min(cfg.init_std, max(cfg.min_std, cfg.focus * float(self._distance(shape,
                                                                                     goal))))
        start = mean + std * self._rng.standard_normal((cfg.samples,) + dims)
        start[0] = mean
        # A move of exactly zero leaves the cord where it is, so it has no gradient: nudge it.
        still = np.linalg.norm(start, axis=-1, keepdims=True) == 0
        start = np.where(still, cfg.min_std * self._rng.standard_normal(start.shape), start)
        best_plan, best_err, rollouts = descend(
            self.dynamics, shape, goal, start, steps=cfg.grad_steps,
            learning_rate=cfg.learning_rate, max_move=cfg.max_move,
            stop_error=cfg.stop_fraction * self.success_threshold,
            direction_free=self.success_metric == "direction_free_error")
        self.stats.rollouts += rollouts
        if cfg.cem_iterations and best_err > cfg.stop_fraction * self.success_threshold:
            best_plan, best_err = self._cem_from(shape, goal, best_plan, best_err)
        self._mean = np.concatenate([best_plan[1:], np.zeros((1,) + dims[1:])])
        self.stats.plans += 1
        self.stats.seconds += time.perf_counter() - t0
        self.stats.predicted_errors.append(best_err)
        return best_plan, best_err

    def _cem_from(self, shape: np.ndarray, goal: np.ndarray, plan: np.ndarray, err: float
                  ) -> tuple[np.ndarray, float]:
        """A few CEM iterations around ``plan`` (scored by ``_score``, latent-mpc's)."""
        cfg = self.config
        mean, std = plan, np.full(plan.shape, cfg.min_std * 2)
        for _ in range(cfg.cem_iterations):
            candidates = mean + std * self._rng.standard_normal((cfg.samples * 8,) + plan.shape)
            candidates[0] = mean
            candidates = clip_moves(candidates, cfg.max_move).astype(np.float64)
            errors = self._score(shape, goal, candidates)
            self.stats.rollouts += len(candidates)
            order = np.argsort(errors)
            if errors[order[0]] < err:
                err, plan = float(errors[order[0]]), candidates[order[0]].copy()
            elite = candidates[order[: cfg.elites]]
            mean, std = elite.mean(axis=0), elite.std(axis=0) + 1e-3
        return plan, err
