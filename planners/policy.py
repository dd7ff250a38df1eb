"""The latent-tree planner as a policy the environment can score.

``PlannerPolicy`` has the interface of Stable-Baselines3 models, ``predict(obs, state,
episode_start, deterministic) -> (action, state)``, so one harness drives planners and RL models.
At the first step of an episode it inverts the observed goal, plans from the observed cord,
and turns the plan's straight end moves into actions of at most ``max_step``. Open loop
(``replan_every=None``) it executes that plan and then holds still. Closed loop it compares the
observed cord with the shape the plan predicts for that moment every ``replan_every`` steps
(deferred to the end of the straight move under way, ``wait_for_corner``), and replans from the
observed cord when they differ by more than ``replan_tolerance`` (and whenever the current plan
is used up, once the cord has come to rest: up to ``settle_steps`` zero actions, as the tasks'
goals are shapes at rest). A plan the real cord follows is kept: replanning from the middle of a
good straight move only risks a worse plan.

When a plan fails (the search budget is spent before the goal is reached) the policy records
the failure in ``stats`` and falls back to the straight-line reference for that plan: the head
moves straight to the goal's head position.

Closed loop, a stall guard ends the episode's motion: after ``patience`` replans in a row that
found the real cord no closer to the goal than the best it has been (by ``min_progress``), the
policy holds still. Without it a near miss keeps being "repaired" by plans whose shapes the
real cord does not follow, and the error grows instead.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dlo_env.errors import InputError
from dlo_env.shapes import error
from planners.episodic_policy import EpisodicPolicy
from planners.interfaces import EpisodeStats, Plan, ShapeSurrogate
from planners.latent_tree import ENDS, LatentTreePlanner
from planners.moves import actions_by_move
from planners.observation import CordObservation
from planners.surrogate import model_n_points

#: The cord counts as at rest when no point moved farther than this in one step, metres.
REST_MOTION = 5e-4
#: Environment steps between checks of the closed-loop policy (``latent-tree-closed``).
DEFAULT_REPLAN_EVERY = 10


@dataclass
class PolicyStats:
    """What the policy did in the current episode.

    Attributes:
        plans: Planning calls.
        failures: Plans that did not reach the goal (the fallback was used instead).
        seconds: Time spent inverting and planning, seconds.
        decoder_calls: Decoder calls of all plans.
        goal_inversion_error: ``error`` of the decoded goal inversion, metres.
        goal_verified: Whether the goal inversion was verified by the model.
        plan_seconds: Seconds of each planning call.
        kept: Closed-loop checks that found the cord following the plan (no replan).
        best_error: Smallest real ``error(cord, goal)`` seen at a replan, metres.
        stalled: Whether the stall guard stopped the motion.
    """

    plans: int = 0
    failures: int = 0
    seconds: float = 0.0
    decoder_calls: int = 0
    goal_inversion_error: float = float("nan")
    goal_verified: bool = False
    plan_seconds: list[float] = field(default_factory=list)
    best_error: float = float("inf")
    stalled: bool = False
    kept: int = 0


class PlannerPolicy(EpisodicPolicy):
    """Plan with a latent-tree planner and act on the environment (SB3 interface).

    A new episode is noticed without ``episode_start``, and a vector env's batch gets one
    plan per environment (``planners.episodic_policy.EpisodicPolicy``).

    Args:
        model: The shape model (``latent_model.ShapeModel`` or the same interface); its
            ``n_points`` must match the environment's cord.
        planner: The planner (default: ``LatentTreePlanner(model)`` with default parameters).
        replan_every: ``None`` for open loop; ``k`` to check the plan against the observed cord
            every ``k`` environment steps (closed loop; the benchmark's agent uses
            ``DEFAULT_REPLAN_EVERY``).
        max_step: The environment's ``max_step`` (metres per unit action).
        replan_tolerance: Closed loop: replan when ``error`` between the observed cord and the
            plan's prediction exceeds this, metres; ``0`` replans at every check. The default
            is about the 95th percentile of the largest deviation along open-loop plans that
            solved their task (linear-2 train split): in the middle of a straight move the
            surrogate's shapes are least accurate even when the move ends right.
        wait_for_corner: Closed loop: defer each check to the end of the straight move under
            way (the surrogate is most accurate at the ends of a move, and a move cut short
            and replanned from its middle often ends worse).
        patience: Closed loop: replans in a row without progress after which the policy holds
            still (``None``: never).
        min_progress: Metres by which the real error must beat its best to count as progress.
        moves_per_plan: Closed loop by moves: execute only the first ``moves_per_plan``
            straight moves of each plan, let the cord come to rest, and plan again from it
            (``None``: the whole plan, checked every ``replan_every`` steps). The kinodynamic
            tree, whose plans are moves predicted at rest, uses 1.
        partial_plans: On a failed plan, follow its path to the node nearest the goal (when
            that node is predicted nearer the goal than the cord is now) instead of the
            straight-line fallback. Worth it when the planner's edges are moves the cord can
            make (the kinodynamic tree), not with latent-line edges.

    Attributes:
        stats: ``PolicyStats`` of the current episode.
        plans: The plans of the current episode, in order; ``plans[0]`` was made from the
            episode's start.
    """

    def __init__(
        self,
        model: ShapeSurrogate,
        planner: LatentTreePlanner | None = None,
        replan_every: int | None = None,
        *,
        max_step: float = 0.02,
        replan_tolerance: float = 0.04,
        wait_for_corner: bool = True,
        settle_steps: int = 10,
        patience: int | None = 3,
        min_progress: float = 0.002,
        moves_per_plan: int | None = None,
        partial_plans: bool = False,
    ) -> None:
        n = model_n_points(model)
        if planner is None:
            planner = LatentTreePlanner(model)
        if planner.n_points != n:
            raise InputError(
                f"planner must plan for the model's n_points={n}, got a planner for "
                f"n_points={planner.n_points}"
            )
        if replan_every is not None and not (isinstance(replan_every, int) and replan_every >= 1):
            raise InputError(f"replan_every must be None or an int >= 1, got {replan_every!r}")
        if not max_step > 0:
            raise InputError(f"max_step must be > 0, got {max_step!r}")
        if patience is not None and not (isinstance(patience, int) and patience >= 1):
            raise InputError(f"patience must be None or an int >= 1, got {patience!r}")
        if not min_progress >= 0:
            raise InputError(f"min_progress must be >= 0, got {min_progress!r}")
        if moves_per_plan is not None and not (isinstance(moves_per_plan, int)
                                               and moves_per_plan >= 1):
            raise InputError(f"moves_per_plan must be None or an int >= 1, got "
                             f"{moves_per_plan!r}")
        self.moves_per_plan = moves_per_plan
        self.partial_plans = bool(partial_plans)
        self.wait_for_corner = bool(wait_for_corner)
        if not (isinstance(settle_steps, int) and settle_steps >= 0):
            raise InputError(f"settle_steps must be an int >= 0, got {settle_steps!r}")
        self.settle_steps = settle_steps
        if not replan_tolerance >= 0:
            raise InputError(f"replan_tolerance must be >= 0, got {replan_tolerance!r}")
        self.replan_tolerance = float(replan_tolerance)
        self.patience = patience
        self.min_progress = float(min_progress)
        self.model = model
        self.planner = planner
        self.replan_every = replan_every
        self.max_step = float(max_step)
        self.n_points = n
        self.reset()

    def check_env(self, env: Any) -> None:
        """Raise ``ValueError`` unless the environment's cord and step match this policy."""
        base = getattr(env, "unwrapped", env)
        params = getattr(base, "params", None)
        n = getattr(params, "n_points", None)
        if n is not None and n != self.n_points:
            raise InputError(
                f"model has n_points={self.n_points} but the environment's cord has "
                f"n_points={n}: use a model trained for this cord"
            )
        step = getattr(base, "max_step", None)
        if step is not None and abs(float(step) - self.max_step) > 1e-12:
            raise InputError(
                f"policy max_step={self.max_step} m differs from the environment's "
                f"max_step={step} m: pass max_step=env.unwrapped.max_step"
            )
        transition = getattr(self.planner, "transition_model", None)
        if transition is not None and params is not None:
            transition.check_env_cord(params)
        if transition is not None and step is not None and abs(
                float(step) - transition.config.max_step) > 1e-12:
            raise InputError(
                f"the transition model was trained with max_step={transition.config.max_step} "
                f"m, but the environment has max_step={step} m")
        grasp = getattr(getattr(base, "cord", None), "grasp", "head")
        if grasp != self.planner.config.grasp:
            raise InputError(
                f"the planner moves the {self.planner.config.grasp!r} end but the environment "
                f"holds {grasp!r}"
            )

    def episode_stats(self) -> EpisodeStats:
        """Planning calls, failures, seconds and the first and latest plans of this episode."""
        return EpisodeStats(
            plans=self.stats.plans,
            failures=self.stats.failures,
            seconds=self.stats.seconds,
            goal_inversion_error=self.stats.goal_inversion_error,
            first_plan=self.plans[0] if self.plans else None,
            latest_plan=self.plans[-1] if self.plans else None,
        )

    def reset(self) -> None:
        """Forget the current episode: plans, queued actions, goal latent and stats."""
        self.stats = PolicyStats()
        self.plans: list[Plan] = []
        self._queue: list[np.ndarray] = []
        self._expected: list[np.ndarray] | None = None
        self._done = 0
        self._corners: set[int] = set()
        self._previous: np.ndarray | None = None
        self._waited = 0
        self._goal_latent: np.ndarray | None = None
        self._goal_key: bytes | None = None
        self._since_plan = 0
        self._no_progress = 0
        self._expect_progress = True  # the executed part of the last plan should end better

    def _stalled(self, shape: np.ndarray, goal: np.ndarray) -> bool:
        """Update the stall guard with the real error now; True when the motion must stop.

        With ``moves_per_plan``, a move that was not the last of a plan predicted to reach the
        goal is a step of that plan, not a stall (a plan may have to move away first)."""
        now = float(error(shape, goal))
        if now < self.stats.best_error - self.min_progress:
            self._no_progress = 0
        elif self._expect_progress:
            self._no_progress += 1
        self.stats.best_error = min(self.stats.best_error, now)
        if self.patience is not None and self._no_progress >= self.patience:
            self.stats.stalled = True
        return self.stats.stalled

    def _on_track(self, shape: np.ndarray) -> bool:
        """Whether the cord is where the current plan predicts it now, with actions left."""
        if not self._queue or self._expected is None or self._done == 0:
            return False
        expected = self._expected[min(self._done, len(self._expected)) - 1]
        return float(error(shape, expected)) <= self.replan_tolerance

    def _replan(self, shape: np.ndarray, goal: np.ndarray, head: np.ndarray) -> None:
        t0 = time.perf_counter()
        key = goal.tobytes()
        if self._goal_latent is None or key != self._goal_key:
            z, err, ok = self.planner.invert(goal[None])
            self._goal_latent, self._goal_key = z[0], key
            self.stats.goal_inversion_error, self.stats.goal_verified = float(err[0]), bool(ok[0])
        plan = self.planner.plan(
            shape, goal, goal_latent=self._goal_latent, seed=self.planner.seed + len(self.plans)
        )
        self.plans.append(plan)
        self.stats.plans += 1
        self.stats.decoder_calls += int(plan.stats.get("decoder_calls", 0))
        follow = plan.success or (self.partial_plans and len(plan.shapes) > 1 and float(
            error(plan.shapes[-1], goal)) < float(error(shape, goal)))
        if not plan.success:
            self.stats.failures += 1
        ends = list(ENDS[self.planner.config.grasp])
        if follow:
            corners = plan.corners[1:]
        elif len(ends) == 1:  # the fallback: straight to the goal's end position
            corners = goal[ends[0]][None]
        else:  # ... the goal's end positions, both ends at once
            corners = goal[ends][None]
        moves = actions_by_move(head, corners, self.max_step)
        if self.moves_per_plan is not None:
            self._expect_progress = not plan.success or len(moves) <= self.moves_per_plan
            moves = moves[: self.moves_per_plan]
        self._queue = [action for move in moves for action in move]
        self._corners = set(np.cumsum([len(move) for move in moves]).tolist())
        self._expected = (expected_shapes(plan, self._queue, self.max_step) if plan.success
                          else None)
        self._done = 0
        self._waited = 0
        if not self._queue and self.replan_every is not None:
            # Nothing to do by this plan (start and goal decode alike): wait instead of
            # replanning at every step.
            self._queue = [self._still()] * self.replan_every
        self._since_plan = 0
        seconds = time.perf_counter() - t0
        self.stats.seconds += seconds
        self.stats.plan_seconds.append(seconds)

    def _still(self) -> np.ndarray:
        """The zero action of the held end(s)."""
        return np.zeros(2 * len(ENDS[self.planner.config.grasp]), dtype=np.float32)

    def _held(self, obs: CordObservation) -> np.ndarray:
        """Where the held end(s) are: ``(2,)`` for one end, ``(E, 2)`` for several (the
        grippers when the observation has them, else the cord's end points)."""
        ends = list(ENDS[self.planner.config.grasp])
        if len(ends) == 1:
            return obs.head
        if len(obs.grippers) == len(ends):
            return obs.grippers
        return obs.shape[ends]

    def _act(self, obs: CordObservation) -> np.ndarray:
        """The next action: plan at the episode's first step; closed loop, check the plan
        (and replan) when due, after letting the cord come to rest."""
        closed = self.replan_every is not None or self.moves_per_plan is not None
        # The pegs the observation shows: a planner with straight-move edges stops its
        # predicted grippers at them (none when the environment has no pegs).
        self.planner.pegs = obs.pegs if len(obs.pegs) else None
        moving = self._previous is not None and float(
            np.abs(obs.shape - self._previous).max()) > REST_MOTION
        self._previous = obs.shape
        if closed and self.plans and not self._queue and moving and (
                self._waited < self.settle_steps):
            self._waited += 1  # let the cord come to rest before judging the plan's outcome
            return self._still()
        due = not self.plans or (closed and (not self._queue or (
            self.moves_per_plan is None and self._since_plan >= self.replan_every
            and (self._done in self._corners or not self.wait_for_corner)
        )))
        if due and closed and self._on_track(obs.shape):
            self.stats.kept += 1
            self._since_plan = 0
        elif due and not self.stats.stalled:
            if closed and self._stalled(obs.shape, obs.goal):
                self._queue = []
            else:
                self._replan(obs.shape, obs.goal, self._held(obs))
        action = self._queue.pop(0) if self._queue else self._still()
        self._since_plan += 1
        self._done += 1
        return action


def _travel(action: np.ndarray) -> float:
    """How far an action moves the end that moves most, in units of ``max_step``."""
    action = np.asarray(action)
    if action.size == 2:
        return float(np.linalg.norm(action))
    return float(np.linalg.norm(action.reshape(-1, 2), axis=1).max())


def expected_shapes(plan: Plan, actions: list[np.ndarray], max_step: float) -> list[np.ndarray]:
    """The shape ``plan`` predicts after each of ``actions`` (its end path, executed in order).

    The end's distance along the plan after each action is matched with the distance at which
    each planned shape was predicted; shapes in between are blended linearly. With both ends
    held, the distance is that of the end that moves farther (both move in proportion).
    """
    steps = np.linalg.norm(np.diff(plan.waypoints.astype(np.float64), axis=0), axis=-1)
    if steps.ndim > 1:
        steps = steps.max(axis=1)
    travel = np.concatenate([[0.0], np.cumsum(steps)])
    done = np.cumsum([_travel(a) * max_step for a in actions])
    out = []
    for s in done:
        j = int(np.clip(np.searchsorted(travel, s, side="right"), 1, len(travel) - 1))
        span = travel[j] - travel[j - 1]
        w = 1.0 if span <= 1e-12 else float(np.clip((s - travel[j - 1]) / span, 0.0, 1.0))
        out.append(((1.0 - w) * plan.shapes[j - 1] + w * plan.shapes[j]).astype(np.float32))
    return out
