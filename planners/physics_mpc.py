"""Physics-in-the-loop planning: the simulator itself as the model (the paper's foil).

``PhysicsMPCPolicy`` plans with the cross-entropy method (CEM) over short sequences of straight
moves of the grasped end(s). Every candidate is scored by simulating it on a fresh copy of the
cord (``Cord.reset`` from the observed shape, then the moves, then a short settle) and measuring
the shape error to the goal. The best plan's first move is executed and the cord left to come
to rest (or ``replan_every`` environment steps of the plan), then the policy plans again from the
observed cord (model-predictive control). It is accurate by
construction, up to the cord's state not being fully observed (velocities are dropped), and slow:
each candidate costs a full simulation. That cost is what the latent-tree planner avoids.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from dlo_env.cord import PEG_RADIUS, Cord, CordParams
from dlo_env.core.checks import non_negative_ints, positive_ints
from dlo_env.errors import InputError
from dlo_env.shapes import cord_length, onto_table, segment_lengths, shape_from_headings
from planners.cem import CEMConfig, CEMPolicy
from planners.observation import CordObservation


@dataclass(frozen=True)
class PhysicsMPCConfig(CEMConfig):
    """CEM budget of physics-mpc and how it simulates and executes a plan. The defaults were
    chosen on the train splits of linear-2, -3 and -5 at 2, 1 and 0.5 cm (judged at rest;
    ``benchmarks/tune_planner.py --agent physics-mpc``, the sweep in docs/history.md): planning
    again from the cord at rest after each move, with a horizon of 3 moves and 32 samples, had
    the best mean success of the settings the sweep completed at 2 and 1 cm, and was within a
    task of the best at 0.5 cm (8 tasks per suite; 64 samples solved more at 1 cm on the two
    suites where that setting finished, at 1.5 times the time).

    Attributes:
        settle_periods: Control periods simulated with the grippers still before scoring.
        replan_every: Environment steps executed between planning calls; None: the first
            move whole, then ``settle_actions`` zero actions, planning again from the cord
            at rest (as latent-mpc does).
        settle_actions: Zero actions after each executed move when ``replan_every`` is None.
    """

    moves: int = 3
    elites: int = 3
    settle_periods: int = 2
    replan_every: int | None = None
    settle_actions: int = 3

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.replan_every is not None:
            positive_ints(self, "replan_every")
        non_negative_ints(self, "settle_actions")


#: Relative difference between the observed length (the shape's polyline at rest) and
#: ``params.length`` above which physics-mpc simulates the observed length.
LENGTH_TOLERANCE = 0.01


def unstretched(shape: np.ndarray) -> np.ndarray:
    """``shape`` ``(n, 2)`` as the simulator can start from it: a cord whose segments differ
    by more than ``LENGTH_TOLERANCE`` is held taut (both grippers pulling it round a peg open
    some joints), which no reset can build; it becomes the cord with the same segment
    directions at the length of its shortest segment (tension only lengthens a segment),
    around the same centroid. A cord with even segments is returned as it is."""
    shape = np.asarray(shape, dtype=np.float64)
    seg = segment_lengths(shape)
    if seg.min() <= 0 or seg.max() <= (1.0 + LENGTH_TOLERANCE) * seg.min():
        return shape  # even, or two points on one spot: nothing to rebuild from
    steps = np.diff(shape, axis=0)
    rebuilt = shape_from_headings(np.arctan2(steps[:, 1], steps[:, 0]), float(seg.min()),
                                  shape[0])
    rebuilt += shape.mean(axis=0) - rebuilt.mean(axis=0)
    return onto_table(rebuilt)  # back onto the table where the rebuilt cord pokes over the rim


def simulate(cord: Cord, shape: np.ndarray, plan: np.ndarray, ends: tuple[str, ...],
             settle_periods: int) -> np.ndarray:
    """The shape at the end of ``plan`` ``(moves, ends, 2)`` of the held ``ends``, simulated on
    ``cord`` reset to ``shape``, after ``settle_periods`` control periods with the grippers
    still."""
    cord.reset(shape)
    for move in plan:
        cord.move(**{end: move[i] for i, end in enumerate(ends)})
    cord.wait(settle_periods)
    return cord.shape


def fitted_cord(cord: Cord, params: CordParams, shape: np.ndarray) -> tuple[Cord, np.ndarray]:
    """A cord of ``params`` that can simulate from the observed ``shape`` (``cord`` itself
    when it is one, else a new one with its grasp and pegs), and the shape to reset it to: a
    taut cord ``unstretched``, and a cord of another length than ``params.length`` (by more
    than ``LENGTH_TOLERANCE``) simulated at its observed length."""
    shape = unstretched(shape)
    length = cord_length(shape)
    if abs(length - params.length) > LENGTH_TOLERANCE * params.length:
        params = replace(params, length=length)
    if params != cord.params:
        cord = Cord(params, grasp=cord.grasp, pegs=cord.pegs, peg_radius=cord.peg_radius)
    return cord, shape


class PhysicsMPCPolicy(CEMPolicy):
    """CEM model-predictive control with the cord simulator as the model.

    Args:
        params: The cord's parameters (those of the environment it acts in).
        grasp: ``"head"`` for ``DLOEndpoint-v0``, ``"both"`` for ``DLODualEndpoint-v0``
            (``"tail"`` for a cord held at the tail).
        max_step: The environment's ``max_step`` (metres per unit action).
        success_threshold: Shape error (metres) below which the policy holds still.
        config: CEM parameters.
        peg_radius: Radius of the environment's pegs, metres; the pegs themselves are read
            from each observation (none without ``max_pegs``) and simulated.

    A cord observed at another length than ``params.length`` (by more than
    ``LENGTH_TOLERANCE``) is simulated at its observed length, the other parameters kept: a
    shape cannot be reset onto a cord of another length, and a cord's length is seen, unlike
    its stiffness, friction or mass.
    """

    def __init__(
        self,
        params: CordParams | None = None,
        grasp: str = "head",
        max_step: float = 0.02,
        success_threshold: float = 0.02,
        config: PhysicsMPCConfig | None = None,
        *,
        success_metric: str = "error",
        peg_radius: float = PEG_RADIUS,
    ) -> None:
        super().__init__(params, grasp, max_step, success_threshold,
                         config if config is not None else PhysicsMPCConfig(),
                         success_metric=success_metric)
        # The model: reset for every candidate.
        self._cord = Cord(self.params, grasp=grasp, peg_radius=peg_radius)

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
            success_metric=base.success_metric,
            peg_radius=base.peg_radius,
        )

    def check_env(self, env: object) -> None:
        """Raise ``ValueError`` unless the environment's cord, grasp and step match this policy."""
        base = getattr(env, "unwrapped", env)
        if (base.params, base.cord.grasp, base.max_step, base.peg_radius) != (
                self.params, self.grasp, self.max_step, self._cord.peg_radius):
            raise InputError(
                f"the physics planner was made for grasp {self.grasp!r}, max_step "
                f"{self.max_step} m, peg_radius {self._cord.peg_radius} m and {self.params}, "
                f"but the environment has grasp {base.cord.grasp!r}, max_step "
                f"{base.max_step} m, peg_radius {base.peg_radius} m and {base.params}: build "
                "it with PhysicsMPCPolicy.for_env(env)"
            )
        self._check_threshold(base)

    def plan(self, shape: np.ndarray, goal: np.ndarray) -> tuple[np.ndarray, float]:
        """Simulate the cord at its observed length when that differs from ``params``'s (a
        taut cord ``unstretched`` first), then plan (CEM over straight moves)."""
        self._cord, shape = fitted_cord(self._cord, self.params, shape)
        return super().plan(shape, goal)

    def _act(self, obs: CordObservation) -> np.ndarray:
        """Simulate the pegs the observation shows, then act as a CEM policy."""
        if not np.array_equal(obs.pegs, self._cord.pegs):
            self._cord.set_pegs(obs.pegs)
        return super()._act(obs)

    def _rollout(self, shape: np.ndarray, plan: np.ndarray) -> np.ndarray:
        """Simulate one candidate ``(moves, ends, 2)`` from ``shape``; return the final shape."""
        return simulate(self._cord, shape, plan, self.ends, self.config.settle_periods)

    def _score(self, shape: np.ndarray, goal: np.ndarray, candidates: np.ndarray) -> np.ndarray:
        """Each candidate simulated on a fresh copy of the cord."""
        return np.array([self._distance(self._rollout(shape, c), goal) for c in candidates])

    def _execute(self, plan: np.ndarray) -> list[np.ndarray]:
        """The actions run before the next planning call: ``replan_every`` steps of the plan,
        or its first move and ``settle_actions`` zero actions."""
        cfg = self.config
        if cfg.replan_every is not None:
            return self._actions(plan)[: cfg.replan_every]
        zero = np.zeros(2 * len(self.ends), dtype=np.float32)
        return self._actions(plan[:1]) + [zero] * cfg.settle_actions


class TrueCordPhysicsMPCPolicy(PhysicsMPCPolicy):
    """physics-mpc told every episode's cord: the oracle of the benchmark on unknown cords.

    It reads the environment's current cord (``env.unwrapped.cord.params``, which the agents
    are otherwise never given) each time it plans, and simulates that cord; everything else is
    ``PhysicsMPCPolicy``. With one fixed cord it is ``PhysicsMPCPolicy.for_env``.

    Args:
        env: The environment it acts in (wrapped or not).
        config: CEM parameters.
    """

    def __init__(self, env: object, config: PhysicsMPCConfig | None = None) -> None:
        base = getattr(env, "unwrapped", env)
        self._env = base
        super().__init__(params=base.cord.params, grasp=base.cord.grasp,
                         max_step=base.max_step, success_threshold=base.success_threshold,
                         config=config, success_metric=base.success_metric,
                         peg_radius=base.peg_radius)

    #: It plans for the one environment it reads (``planners.PerEnvPolicy`` for a vector env).
    plans_batches = False

    def check_env(self, env: object) -> None:
        """Raise ``ValueError`` unless ``env`` is the environment this policy reads."""
        if getattr(env, "unwrapped", env) is not self._env:
            raise InputError("TrueCordPhysicsMPCPolicy reads the cord of the environment it "
                             "was made for: build it with TrueCordPhysicsMPCPolicy(env)")
        self._check_threshold(self._env)

    def plan(self, shape: np.ndarray, goal: np.ndarray) -> tuple[np.ndarray, float]:
        """Simulate the environment's current cord, then plan as ``PhysicsMPCPolicy``."""
        self.params = self._env.cord.params
        return super().plan(shape, goal)

    def _copies(self, size: int) -> list:
        if size > 1:
            raise InputError("TrueCordPhysicsMPCPolicy reads the cord of the one environment "
                             f"it was made for: it takes a batch of 1, got {size} observations; "
                             "in a vector env give each environment its own with "
                             "planners.PerEnvPolicy")
        return super()._copies(size)
