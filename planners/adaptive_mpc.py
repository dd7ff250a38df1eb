"""latent-mpc-adaptive: latent-mpc that fits the cord's parameters to the moves it has seen.

A cord whose stiffness, friction, mass or length are unknown moves differently from the
default cord. With a transition model conditioned on the cord
(``TransitionModelConfig.cord_inputs``), :class:`AdaptiveLatentMPCPolicy` starts an episode
from the default cord and, each time it plans, first fits the cord to every move of the
episode so far: each executed move is a start shape at rest, the held end(s)' displacement
and the shape at rest after it, and the fitted cord is the one whose predictions of those
moves are nearest the observed shapes. The fit is a seeded random search in the logarithm
of the parameters inside the ranges the model was trained on (``AdaptConfig``): candidates
drawn over the whole box, then rounds of candidates around the best so far, every round one
batched ``predict`` call. The cord's length is not fitted but read off the observed shape (a
cord at rest is as long as its polyline), from the first plan on. The plan then scores its
candidates with the fitted cord.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dlo_env.core.checks import positive_ints
from dlo_env.dataset.transitions import PARAM_COLUMNS
from dlo_env.errors import InputError
from dlo_env.randomize import DEFAULT_RANGES, check_randomize, trained_ranges
from dlo_env.shapes import cord_length, error
from planners.latent_mpc import LatentMPCConfig, LatentMPCPolicy


@dataclass(frozen=True)
class AdaptConfig:
    """How the cord is fitted to the episode's moves.

    Attributes:
        ranges: Parameter -> (low, high) searched (the others stay the default cord's). None:
            the ranges the model's training data was drawn from (``dlo collect transitions
            --randomize``), else ``dlo_env.randomize.DEFAULT_RANGES``.
        candidates: Cords scored per round.
        rounds: Rounds after the first, each around the best cord so far with half the spread.
        min_moves: Moves seen before the first fit (before it: the default cord, with the
            observed length).
        seed: Seed of the search (the same moves give the same cord).
        observe_length: Read the length off the observed shape (its polyline length, the
            length of a cord at rest) at every plan instead of fitting it.
    """

    ranges: Mapping[str, tuple[float, float]] | None = None
    candidates: int = 128
    rounds: int = 3
    min_moves: int = 1
    seed: int = 0
    observe_length: bool = True

    def __post_init__(self) -> None:
        positive_ints(self, "candidates", "min_moves")
        if not (isinstance(self.rounds, int) and self.rounds >= 0):
            raise InputError(f"AdaptConfig.rounds must be an int >= 0, got {self.rounds!r}")
        if self.ranges is not None:
            check_randomize(self.ranges, "AdaptConfig.ranges")


@dataclass
class _Move:
    start: np.ndarray  # (n, 2) at rest
    displacement: np.ndarray  # (2 * ends,) what the held ends did
    end: np.ndarray  # (n, 2) at rest


@dataclass
class AdaptStats:
    """What the fits of an episode found: the cord after each fit (rows of
    ``PARAM_COLUMNS``) and its mean error on the moves seen, metres."""

    cords: list[list[float]] = field(default_factory=list)
    errors: list[float] = field(default_factory=list)


class AdaptiveLatentMPCPolicy(LatentMPCPolicy):
    """latent-mpc on a cord-conditioned transition model, fitting the cord as it goes.

    Args:
        model: A ``latent_model.TransitionModel`` with ``config.cord_inputs``.
        grasp: As ``LatentMPCPolicy``.
        success_threshold: As ``LatentMPCPolicy``.
        config: As ``LatentMPCPolicy``.
        success_metric: As ``LatentMPCPolicy``.
        adapt: How the cord is fitted.
    """

    def __init__(self, model: Any, grasp: str = "head", success_threshold: float = 0.02,
                 config: LatentMPCConfig | None = None, *, success_metric: str = "error",
                 adapt: AdaptConfig | None = None) -> None:
        if not getattr(model.config, "cord_inputs", False):
            raise InputError("model must be a transition model conditioned on the cord "
                             "(TransitionModelConfig.cord_inputs; dlo train transition "
                             "--cord-inputs)")
        self.adapt = adapt if adapt is not None else AdaptConfig()
        self.default_row = np.array([getattr(model.cord_params, k) for k in PARAM_COLUMNS])
        self.ranges = self._ranges(model, self.adapt)
        super().__init__(model, grasp, success_threshold, config, success_metric=success_metric)

    @staticmethod
    def _ranges(model: Any, adapt: AdaptConfig) -> dict[str, tuple[float, float]]:
        if adapt.ranges is not None:
            return dict(check_randomize(adapt.ranges, "AdaptConfig.ranges"))
        trained = trained_ranges(getattr(model, "info", {}) or {})
        return dict(check_randomize(trained, "the model's training ranges")) if trained \
            else dict(DEFAULT_RANGES)

    @classmethod
    def for_env(cls, env: object, config: LatentMPCConfig | None = None, model: Any = None,
                adapt: AdaptConfig | None = None) -> AdaptiveLatentMPCPolicy:
        """Build the policy for a ``dlo_env`` environment. The cord's parameters are not told
        to the model, they are what the policy fits; the environment's own cord must lie in the
        model's training ranges (``TransitionModel.check_env_cord``)."""
        if model is None:
            raise InputError("model is required: a transition model of several cords "
                             "(TransitionModel.load_pretrained(cords=True) is the shipped one)")
        base = getattr(env, "unwrapped", env)
        policy = cls(model, grasp=base.grasp, success_threshold=base.success_threshold,
                     config=config, success_metric=base.success_metric, adapt=adapt)
        policy.check_env(env)
        policy.peg_radius = base.peg_radius  # of the pegs it will observe
        return policy

    def _polish_cord(self) -> Any:
        """The polish predicts the cord fitted so far."""
        from dataclasses import replace

        return replace(self.model.cord_params, **dict(zip(PARAM_COLUMNS, map(float,
                                                                             self.cord_row))))

    def reset(self) -> None:
        """Forget the plan, the moves seen and the fitted cord (back to the default cord)."""
        super().reset()
        self.moves_seen: list[_Move] = []
        self.cord_row = np.array(self.default_row, dtype=np.float64)
        self.adapt_stats = AdaptStats()
        self._pending: tuple[np.ndarray, np.ndarray] | None = None

    # ------------------------------------------------------------------ fitting
    def fit(self, moves: list[_Move]) -> tuple[np.ndarray, float]:
        """The cord (a row of ``PARAM_COLUMNS``) whose predictions of ``moves`` are nearest
        what the cord did, and its mean error there (metres)."""
        cfg = self.adapt
        rng = np.random.default_rng(cfg.seed)
        names = [k for k in PARAM_COLUMNS if k in self.ranges
                 and not (k == "length" and cfg.observe_length)]
        cols = [PARAM_COLUMNS.index(k) for k in names]
        low = np.log([self.ranges[k][0] for k in names])
        high = np.log([self.ranges[k][1] for k in names])
        best = np.array(self.cord_row, dtype=np.float64)
        best_error = math.inf
        spread = high - low
        for round_ in range(cfg.rounds + 1):
            if round_ == 0:
                logs = rng.uniform(low, high, size=(cfg.candidates, len(cols)))
            else:
                spread = spread / 2
                logs = np.clip(np.log(best[cols]) + rng.normal(size=(cfg.candidates, len(cols)))
                               * spread / 2, low, high)
            rows = np.tile(best, (cfg.candidates + 1, 1))
            rows[:-1, cols] = np.exp(logs)  # the last row: the best so far (or the default)
            errors = self._errors(rows, moves)
            i = int(np.argmin(errors))
            if errors[i] < best_error:
                best, best_error = rows[i], float(errors[i])
        return best, best_error

    def _errors(self, rows: np.ndarray, moves: list[_Move]) -> np.ndarray:
        """Mean prediction error over ``moves`` of each cord of ``rows``, one batched call."""
        c, h = len(rows), len(moves)
        starts = np.stack([m.start for m in moves])
        ends = np.stack([m.end for m in moves])
        shifts = np.stack([m.displacement for m in moves])
        # the pegs observed this episode stop the grippers as they did (a move that touched one
        # is not blamed on the cord)
        pred = super()._predict(np.tile(starts, (c, 1, 1)), np.tile(shifts, (c, 1)),
                                params=np.repeat(rows, h, axis=0), members=self.members,
                                inextensible=self.config.inextensible)
        return np.asarray(error(pred, np.tile(ends, (c, 1, 1)))).reshape(c, h).mean(axis=1)

    # ------------------------------------------------------------------ planning
    def plan(self, shape: np.ndarray, goal: np.ndarray) -> tuple[np.ndarray, float]:
        """Record the move that brought the cord here, refit the cord, then plan with it."""
        if self.adapt.observe_length:
            length = PARAM_COLUMNS.index("length")
            self.cord_row[length] = cord_length(shape)
        if self._pending is not None:
            start, ends_before = self._pending
            moved = (self._end_points(shape) - ends_before).reshape(-1)
            if np.abs(moved).max() > 1e-6:
                self.moves_seen.append(_Move(start, moved.astype(np.float32), shape.copy()))
            if len(self.moves_seen) >= self.adapt.min_moves:
                self.cord_row, fit_error = self.fit(self.moves_seen)
                self.adapt_stats.cords.append(self.cord_row.tolist())
                self.adapt_stats.errors.append(fit_error)
        self._pending = (shape.copy(), self._end_points(shape))
        return super().plan(shape, goal)

    def _predict(self, shapes: np.ndarray, moves: np.ndarray, **kw: Any) -> Any:
        return super()._predict(shapes, moves, params=self.cord_row, **kw)
